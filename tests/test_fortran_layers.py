"""The Fortran core's layers are its folders: a module uses only modules of
its own layer and of those below (docs/architecture.md), no file is over
1,200 lines (a longer one wants splitting by what it does), and only
fortran/app/ may stop.  Reads the source tree beside this file; skips where
the tree is not there (an installed package alone)."""

import re
from pathlib import Path

import pytest

FORTRAN = Path(__file__).resolve().parents[1] / "fortran"

#: Layers, lowest first; a folder below a layer (estimation/fit) is that layer,
#: ranked by its own entry where it has one.
RANK = ["base", "numerics", "models", "estimation",
        "estimation/time_domain", "estimation/frequency_domain", "estimation/online",
        "estimation/regression", "estimation/fit",
        "design", "case", "api", "app"]
#: Sub-layers that are siblings: neither uses the other.
SIBLINGS = {("estimation/time_domain", "estimation/frequency_domain")}
MAX_LINES = 1200

pytestmark = pytest.mark.skipif(not FORTRAN.is_dir(), reason="no source tree beside the tests")

USE = re.compile(r"^\s*use\s+(mlid_\w+)", re.I | re.M)
DEFINES = re.compile(r"^\s*(?:module|submodule\s*\(\s*\w+\s*\))\s+(mlid_\w+)\s*$", re.I | re.M)


def layer_of(path):
    rel = path.parent.relative_to(FORTRAN).as_posix()
    while rel not in RANK:
        assert "/" in rel, f"{path}: folder {rel} is no layer"
        rel = rel.rsplit("/", 1)[0]
    return rel


def sources():
    return sorted(FORTRAN.rglob("*.f90"))


def test_every_file_is_in_a_layer_folder():
    assert sources()
    for f in sources():
        assert f.parent != FORTRAN, f"{f.name} sits at the top of fortran/, in no layer"
        layer_of(f)


def test_modules_use_only_their_layer_and_below():
    home = {}
    for f in sources():
        for name in DEFINES.findall(f.read_text()):
            home[name.lower()] = layer_of(f)
    wrong = []
    for f in sources():
        mine = layer_of(f)
        for used in USE.findall(f.read_text()):
            theirs = home.get(used.lower())
            if theirs is None:
                continue                      # a module of the app's own file
            if RANK.index(theirs) > RANK.index(mine) or (mine, theirs) in SIBLINGS \
                    or (theirs, mine) in SIBLINGS:
                wrong.append(f"{f.relative_to(FORTRAN)} ({mine}) uses {used} ({theirs})")
    assert not wrong, "upward or sideways uses:\n" + "\n".join(wrong)


def test_no_file_over_its_limit():
    long = [f"{f.relative_to(FORTRAN)}: {n} lines" for f in sources()
            if (n := len(f.read_text().splitlines())) > MAX_LINES]
    assert not long, "split by what they do:\n" + "\n".join(long)


def test_only_the_programs_stop():
    stop = re.compile(r"^\s*(error\s+)?stop\b", re.I | re.M)
    found = [str(f.relative_to(FORTRAN)) for f in sources()
             if layer_of(f) != "app" and stop.search(f.read_text())]
    assert not found, f"library code must return a status, not stop: {found}"


#: The most arguments a routine of the flat interface may take, its sizes
#: included (issue 40): what a call needs besides its handle goes by name
#: (mlid_api_problem's parts, mlid_api_values' values, results by name).
MAX_ARGS = 12
HEADER = re.compile(r"^\s*subroutine\s+(\w+)\s*\(([^)]*)\)", re.I | re.M)


def wrapped_routines():
    """(file, routine, its arguments) of each public subroutine of fortran/api/."""
    for f in sorted((FORTRAN / "api").glob("*.f90")):
        text = f.read_text()
        public = {n.strip().lower()
                  for block in re.findall(r"^\s*public\s*::\s*((?:[^\n]*&\s*\n)*[^\n]*)", text,
                                          re.I | re.M)
                  for n in block.replace("&", " ").split(",")}
        for name, args in HEADER.findall(re.sub(r"&\s*\n\s*&?", " ", text)):
            if name.lower() in public:
                yield f.name, name, [a for a in args.split(",") if a.strip()]


def test_no_wrapped_routine_takes_more_than_twelve_arguments():
    found = list(wrapped_routines())
    assert len(found) > 40                    # the parse found the interface
    long = [f"{f}: {name} takes {len(args)}" for f, name, args in found if len(args) > MAX_ARGS]
    assert not long, "\n".join(long)
