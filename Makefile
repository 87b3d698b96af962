# Two commands do all set-up on a fresh Debian machine with Python 3.11 (as root):
#   make demo   install what is missing, then run the C-8 case and print the report
#   make test   install what is missing, then pytest (installed package), meson test and
#               the documentation site (make docs)
# make docs builds the site into docs/_build/html (Sphinx, warnings as errors; FORD's
# Fortran API in docs/_build/html/fortran).
# make install NATIVE=true builds the Fortran core for this machine's processor
# (meson option native: -march=native); make install alone goes back to the portable core.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
VPY := $(VENV)/bin/python
BUILD := build
NATIVE ?= false
STAMP := $(VENV)/.mlid-installed-native-$(NATIVE)
DEPS := $(VENV)/.mlid-deps
SOURCES := $(shell find fortran python -name '*.f90' -o -name '*.py' -o -name '*.c' -o -name '*.j2' \
             -o -name 'meson.build') \
           meson.build meson.options pyproject.toml
APT := DEBIAN_FRONTEND=noninteractive apt-get install -y -q

.PHONY: demo test docs install sysdeps bench clean

demo: install
	$(VENV)/bin/mlid run cases/c8_short_period/c8.nml --plots $(BUILD)/plots --json $(BUILD)/c8.json

# the docs first: the tests compare the pages a build wrote with what the core says now
test: install
	$(MAKE) --no-print-directory docs
	$(VPY) -m pytest tests -q
	$(VENV)/bin/meson test -C $(BUILD) --print-errorlogs

# The documentation site: Sphinx (its gallery's examples run, their figures made; the deck
# reference made from the core's tables), then FORD's Fortran API into its fortran/ folder.
docs: install
	$(VPY) -m sphinx -W --keep-going -q -b html docs docs/_build/html
	$(VENV)/bin/ford -q docs/fortran_api.md
	test -f docs/_build/html/fortran/index.html

bench: install
	$(VPY) -m pip install -q statsmodels
	$(VPY) benchmarks/bench_fit.py
	$(VPY) benchmarks/bench_hfb320.py
	$(VPY) benchmarks/bench_speed.py
	$(VPY) benchmarks/bench_threads.py --rounds 3
	$(VPY) benchmarks/bench_deck.py
	$(VPY) benchmarks/monte_carlo_c8.py
	$(VPY) benchmarks/monte_carlo_m2f3.py
	$(VPY) benchmarks/peer_statsmodels_m2f3.py
	$(VPY) benchmarks/bench_rank_search.py
	$(VPY) benchmarks/bench_x22.py
	$(VPY) benchmarks/bench_freq_tools.py
	$(VPY) benchmarks/bench_frequency.py
	$(VPY) benchmarks/bench_design.py
	$(VPY) benchmarks/monte_carlo_10k.py
	$(VPY) benchmarks/diagnose_scenarios.py

install: sysdeps $(STAMP)

# System packages from Debian: gfortran, LAPACK/BLAS, zlib and HDF5 (the core reads .mat
# and HDF5 records), venv and headers for Python, chromium (the HTML report's screenshot test).
sysdeps:
	@missing=""; \
	command -v gfortran >/dev/null || missing="$$missing gfortran"; \
	dpkg -s liblapack-dev >/dev/null 2>&1 || missing="$$missing liblapack-dev libblas-dev"; \
	dpkg -s zlib1g-dev >/dev/null 2>&1 || missing="$$missing zlib1g-dev"; \
	dpkg -s libhdf5-dev >/dev/null 2>&1 || missing="$$missing libhdf5-dev"; \
	command -v chromium >/dev/null || missing="$$missing chromium"; \
	$(PYTHON) -c 'import ensurepip, venv' 2>/dev/null || missing="$$missing python3-venv"; \
	$(PYTHON) -c 'import sysconfig, os, sys; sys.exit(not os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")))' \
	  || missing="$$missing python3-dev"; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" != 0 ]; then echo "mlid: need Debian packages:$$missing (run as root or install them)"; exit 1; fi; \
	  echo "installing:$$missing"; apt-get update -q && $(APT) $$missing; \
	fi

$(VPY):
	$(PYTHON) -m venv $(VENV)
	$(VPY) -m pip install -q --upgrade pip

# The venv's packages, installed again when this list changes.
$(DEPS): $(VPY) Makefile
	$(VPY) -m pip install -q meson meson-python ninja numpy matplotlib scipy h5py pandas xarray pytest dask distributed hypothesis tqdm jinja2
	$(VPY) -m pip install -q jsbsim || echo "mlid: no jsbsim for this Python: the JSBSim flights of tests/test_export_jsbsim.py will be skipped"
	$(VPY) -m pip install -q sphinx numpydoc pydata-sphinx-theme myst-parser sphinx-gallery ford
	touch $(DEPS)

# Build with meson-python into ./build (kept, so meson test can run there); the
# stamp names the native setting, so that changing it builds again.  A build
# directory set up before meson.options gained an option takes -D for it only
# after a plain reconfigure.
$(STAMP): $(DEPS) $(SOURCES)
	if [ -f $(BUILD)/build.ninja ]; then $(VENV)/bin/meson setup --reconfigure $(BUILD) >/dev/null 2>&1 || true; fi
	$(VPY) -m pip install -q --no-build-isolation -Cbuild-dir=$(BUILD) -Csetup-args=-Dnative=$(NATIVE) .
	rm -f $(VENV)/.mlid-installed*
	touch $(STAMP)

clean:
	rm -rf $(BUILD) $(VENV)
