"""The docstrings' examples run as doctests (issue 42): every module of the
installed package, as the API pages show them (numpydoc's Examples
sections).  A module whose examples fail fails here, by name."""

import doctest
import importlib
import pkgutil

import numpy as np
import pytest

import mlid

#: Every module but the extension and __main__ (importing it runs the command).
MODULES = sorted(m.name for m in pkgutil.walk_packages(mlid.__path__, "mlid.")
                 if not m.name.startswith("mlid._core") and m.name != "mlid.__main__")
#: Modules with Examples sections; a test below checks each has some, so
#: that a docstring rewritten without them is noticed.
WITH_EXAMPLES = ("mlid.data.flight_data", "mlid.model.models", "mlid.estimate.fit",
                 "mlid.frequency.fourier", "mlid.frequency.responses", "mlid.design.signals",
                 "mlid.online.rls", "mlid.online.ftr")


def examples(name):
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    return [t for t in finder.find(module, name) if t.examples]


@pytest.mark.parametrize("name", MODULES)
def test_the_examples_of_a_module_run(name):
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    with np.printoptions(legacy=False):
        for test in examples(name):
            runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} examples failed"


@pytest.mark.parametrize("name", WITH_EXAMPLES)
def test_the_public_functions_show_examples(name):
    assert sum(len(t.examples) for t in examples(name)) >= 2
