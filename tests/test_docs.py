"""The documentation site (issue 42): the deck reference lists every group and
name the core's deck reader takes, and nothing else; the core's table of them
is the reader's own (its namelist statements, and what a deck may give); the
README's "Read on" points to pages of the site; every public name is on the
API page.  The site itself is built by `make docs` (warnings are errors).
Reads the source tree beside this file; skips where it is not there."""

import importlib.util
import re
from pathlib import Path

import pytest

import mlid
from mlid._bridge import api, text

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
pytestmark = pytest.mark.skipif(not (DOCS / "_ext").is_dir(), reason="no docs beside the tests")


def generator():
    spec = importlib.util.spec_from_file_location("deck_reference",
                                                  DOCS / "_ext" / "deck_reference.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def core_table():
    """{group: set of names} as the core's deck reader lists them."""
    table = {}
    for line in text(api.mlid_deck_groups()).splitlines():
        group, jobs, keys = line.split("|")
        table[group] = set(keys.split())
    return table


def page_table(page):
    """{group: set of names} as the generated page lists them: the first cell
    of each table row under '## &group'."""
    table, group = {}, None
    for line in page.splitlines():
        if line.startswith("## &"):
            group = line[4:].strip()
            table[group] = set()
        elif group and line.startswith("| `"):
            first = re.split(r"(?<!\\)\|", line)[1]
            table[group] |= set(re.findall(r"`([^`]+)`", first))
    return table


def test_the_deck_reference_lists_every_name_the_reader_takes():
    core = core_table()
    assert set(core) == {"case", "model", "data", "simulate", "estimate", "design",
                         "monte_carlo", "online", "stepwise"}
    assert sum(len(k) for k in core.values()) > 100
    assert page_table(generator().make_page()) == core


def test_the_written_page_is_the_generators(tmp_path):
    """The page a docs build wrote (when there was one) is what the core says now."""
    page = DOCS / "reference" / "deck.md"
    if not page.exists():
        pytest.skip("no docs built here (make docs)")
    assert page_table(page.read_text(encoding="utf-8")) == core_table()


def test_an_option_shows_the_cores_default_and_choices():
    page = generator().make_page()
    row = next(r for r in page.splitlines() if r.startswith("| `max_iter` |"))
    assert f"`{mlid.default_options()['max_iter']}`" in row
    row = next(r for r in page.splitlines() if r.startswith("| `method` |")
               and "filter_error" in r)
    assert "`'output_error'` (or `'filter_error'`, `'frequency_output_error'`, " \
           "`'frequency_equation_error'`)" in row


def test_a_name_without_meaning_or_a_meaning_without_name_stops_the_page():
    gen = generator()
    groups, options, items = gen.core_groups(), gen.core_options(), gen.read_items()
    with pytest.raises(gen.DeckReferenceError, match="&simulate seed"):
        gen.make_page(groups, options, [e for e in items if e[:2] != ("simulate", ["seed"])])
    with pytest.raises(gen.DeckReferenceError, match="takes no name frobnicate"):
        gen.make_page(groups, options, items + [("data", ["frobnicate"], None, "x")])
    with pytest.raises(gen.DeckReferenceError, match="an option's default is the core's"):
        gen.make_page(groups, options, [(g, n, "30" if n == ["max_iter"] else d, m)
                                        for g, n, d, m in items])


NAMELIST = re.compile(r"namelist\s*/(\w+)/((?:[^\n]*&\s*\n)*[^\n]*)", re.I)


def test_the_cores_table_is_the_readers_namelists():
    """GROUP_KEYS holds the names of each reader's namelist statement."""
    found = {}
    for path in sorted((ROOT / "fortran" / "case").glob("mlid_deck_*.f90")):
        for group, body in NAMELIST.findall(path.read_text(encoding="utf-8")):
            found[group.lower()] = {n.strip().lower() for n in body.replace("&", " ").split(",")}
    assert found == core_table()


#: A case that reads, for each job: its groups in the order they are read.
GOOD = {"estimate": {"model": "kind = 'linear', nx = 1, nu = 1, ny = 1, f = -1, g = 1, h = 1",
                     "data": "file = 'r.dat', input_cols = 2, output_cols = 3", "estimate": ""},
        "simulate": {"model": "nx = 1, nu = 1, ny = 1, f = -1, g = 1, h = 1",
                     "simulate": "out = 'o.dat', t_end = 1, dt = 0.1"},
        "design": {"model": "nx = 1, nu = 1, ny = 1, f = -1, g = 1, h = 1, r = 1, "
                            "free = 'g(1,1)'",
                   "design": "t_end = 1, dt = 0.1, energy = 1, out = 'o.dat'"},
        "monte_carlo": {"model": "nx = 1, nu = 1, ny = 1, f = -1, g = 1, h = 1, r = 1, "
                                 "free = 'g(1,1)'",
                        "monte_carlo": "runs = 2, input_file = 'r.dat'", "estimate": ""}}


@pytest.mark.parametrize("group", ["case", "model", "data", "simulate", "estimate", "design",
                                   "monte_carlo"])
def test_the_reader_takes_every_name_of_the_table(group, tmp_path):
    """A deck that gives a name of the table is not refused as an unknown
    name (a value it does not like is another message); one the table lacks is."""
    job = group if group in GOOD else "estimate"
    (tmp_path / "r.dat").write_text("0 0 0\n0.1 0 0\n0.2 0 0\n")
    deck = tmp_path / "d.nml"
    deck.write_text(f"&case job = '{job}' /\n" + "".join(
        f"&{g} {body} /\n" for g, body in GOOD[job].items()))
    assert read_one(deck) == "", "the case without the name should read"
    for name in sorted(core_table()[group]) + ["no_such_name"]:
        groups = dict(GOOD[job], case=f"job = '{job}'")
        groups[group] = ", ".join(s for s in (f"{name} = 1", groups[group]) if s)
        order = ["case"] + list(GOOD[job])
        deck.write_text("".join(f"&{g} {groups[g]} /\n" for g in order))
        message = read_one(deck)
        unknown = f"unknown name {name}" in message
        assert unknown == (name == "no_such_name"), (group, name, message)


def read_one(deck):
    """The message of the deck's one case ('' when it reads)."""
    (case,) = mlid.read_deck(deck)
    return case.error or ""


def toctree_pages():
    """The site's pages reachable from index.md through its toctrees (as docs/ paths)."""
    seen, todo = set(), [DOCS / "index.md"]
    while todo:
        page = todo.pop()
        if page in seen or not page.exists():
            continue
        seen.add(page)
        for block in re.findall(r"```\{toctree\}\n(.*?)```", page.read_text(encoding="utf-8"),
                                re.S):
            for entry in block.splitlines():
                if entry.strip() and not entry.startswith(":"):
                    todo.append((page.parent / (entry.strip() + ".md")).resolve())
    return seen


def test_the_readme_reads_on_in_the_site():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    read_on = readme.split("## Read on", 1)[1].split("\n## ", 1)[0]
    assert "make docs" in read_on and "docs/_build/html/index.html" in read_on
    links = re.findall(r"\]\(([^)#]+)\)", read_on)
    assert len(links) >= 6
    pages = toctree_pages()
    for target in links:
        path = (ROOT / target).resolve()
        assert path in pages or path == DOCS / "examples", (target, "not a page of the site")


def test_every_public_name_is_on_the_api_page():
    listed = set(re.findall(r"^   (\w+)$", (DOCS / "api.rst").read_text(encoding="utf-8"), re.M))
    assert set(mlid.__all__) <= listed, set(mlid.__all__) - listed
