"""docs/architecture.md stays true to the tree: every path it names in
backticks under fortran/, python/, tests/, benchmarks/ or cases/ exists, and
each row of its equation table names one Fortran file that defines the module
the row names (every ``mlid_*`` word) and the routines of its last column.
Reads the source tree beside this file; skips where the tree is not there (an
installed package alone)."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "architecture.md"

#: The folders whose paths the page may name; a path under any other is not checked.
CHECKED = ("fortran/", "python/", "tests/", "benchmarks/", "cases/")
#: The heading of the equation table, and how many rows it has at least: a
#: table that parsed to nothing would otherwise pass.
TABLE_HEADING = "## Where each equation lives"
MIN_ROWS = 25

pytestmark = pytest.mark.skipif(not (ROOT / "fortran").is_dir(),
                                reason="no source tree beside the tests")

TICKED = re.compile(r"`([^`\n]+)`")
MLID_WORD = re.compile(r"\bmlid_\w+")
MODULE = re.compile(r"^\s*module\s+(\w+)\s*(?:!.*)?$", re.I | re.M)
# a procedure's or a type's definition, not its end line and not a comment
PROCEDURE = re.compile(r"^(?!\s*end\b)[^!\n]*?\b(?:subroutine|function)\s+(\w+)", re.I | re.M)
# a derived type's definition (type :: name, type, extends(x) :: name), not a
# declaration of type(x)
TYPE = re.compile(r"^\s*type\s*(?:,[^:\n]*)?::\s*(\w+)", re.I | re.M)


def text():
    return DOC.read_text(encoding="utf-8")


def table_rows():
    """The equation table's rows, each as its cells (a \\| inside a cell is text)."""
    body = text().split(TABLE_HEADING, 1)[1].split("\n## ", 1)[0]
    rows = [line for line in body.splitlines() if line.startswith("|")]
    cells = [[c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", r)[1:-1]]
             for r in rows[2:]]              # after the header and the --- line
    return cells


def label(cells):
    """A row as a failure names it: its source and the start of what it is."""
    return f"{cells[0]} ({cells[1][:40]})"


def defined(path):
    """The modules, and the procedures and types, a Fortran file defines (lower case)."""
    src = path.read_text(encoding="utf-8", errors="replace")
    modules = {m.lower() for m in MODULE.findall(src)}
    names = {n.lower() for n in PROCEDURE.findall(src) + TYPE.findall(src)}
    return modules, names


def test_the_page_is_there():
    assert DOC.is_file(), f"{DOC.relative_to(ROOT)} is missing"
    assert TABLE_HEADING in text()


def test_every_named_path_exists():
    named = sorted({t for t in TICKED.findall(text()) if t.startswith(CHECKED)})
    assert named, "the page names no path at all"
    missing = [p for p in named if not (ROOT / p).exists()]
    assert not missing, "paths named in docs/architecture.md that do not exist:\n" + \
        "\n".join(missing)


def test_each_equation_row_names_one_file_that_defines_its_module():
    rows = table_rows()
    assert len(rows) >= MIN_ROWS, f"the equation table has {len(rows)} rows"
    wrong = []
    for cells in rows:
        line, row = " | ".join(cells), label(cells)
        files = [t for t in TICKED.findall(line) if t.startswith("fortran/")]
        if len(files) != 1 or not files[0].endswith(".f90"):
            wrong.append(f"{row}: names {len(files)} Fortran paths, not one file")
            continue
        path = ROOT / files[0]
        if not path.is_file():
            wrong.append(f"{row}: {files[0]} does not exist")
            continue
        modules, _ = defined(path)
        for word in sorted({w.lower() for w in MLID_WORD.findall(line)}):
            if word not in modules:
                wrong.append(f"{row}: module {word} is not defined in {files[0]}")
    assert not wrong, "equation table rows that do not hold:\n" + "\n".join(wrong)


def test_each_equation_row_names_routines_its_file_defines():
    wrong = []
    for cells in table_rows():
        files = [t for t in TICKED.findall(" | ".join(cells)) if t.startswith("fortran/")]
        if len(files) != 1 or not (ROOT / files[0]).is_file():
            continue                          # the test above says why
        routines = [t for t in TICKED.findall(cells[-1]) if re.fullmatch(r"\w+", t)]
        if not routines:
            wrong.append(f"{label(cells)}: no routine named")
        _, names = defined(ROOT / files[0])
        wrong += [f"{label(cells)}: {r} is not defined in {files[0]}" for r in routines
                  if r.lower() not in names]
    assert not wrong, "equation table rows that do not hold:\n" + "\n".join(wrong)
