"""The README is the front door (issue 42): its first fit in Python runs as
written and gives the deck's estimates, and every page it and the guide
link to is there."""

import re
import shutil
import subprocess

import pytest

from conftest import BIN, REPO

README = REPO / "README.md"


def test_the_first_fit_in_python_runs_as_written(tmp_path, monkeypatch):
    shutil.copytree(REPO / "cases" / "c8_short_period", tmp_path / "cases" / "c8_short_period")
    deck = "cases/c8_short_period/c8.nml"
    batch = subprocess.run([str(BIN / "mlid-batch"), deck, "--json", "c8.json"], cwd=tmp_path,
                           capture_output=True, text=True, timeout=300)
    assert batch.returncode == 0, batch.stderr
    code = re.search(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.S).group(1)
    monkeypatch.chdir(tmp_path)
    space = {}
    exec(compile(code, "README.md", "exec"), space)
    res = space["res"]
    assert res.converged
    import json
    deck_fit = json.loads((tmp_path / "c8.json").read_text())[1]
    assert list(res.params.index) == deck_fit["parameters"]
    assert res.params["estimate"].tolist() == pytest.approx(deck_fit["estimate"], rel=1e-9)


@pytest.mark.parametrize("page", ["README.md", *sorted(
    str(p.relative_to(REPO)) for p in (REPO / "docs" / "guide").glob("*.md"))])
def test_every_link_leads_somewhere(page):
    path = REPO / page
    for target in re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", path.read_text(encoding="utf-8")):
        if "://" in target:
            continue
        where = (path.parent / target).resolve()
        # a page the docs build makes (make docs; a clean clone has not built them yet)
        assert where.exists() or where in _made_pages(), (page, target)


def _made_pages():
    """The pages the docs build writes into docs/, as its extensions name them."""
    import importlib.util
    made = set()
    for ext in ("deck_reference", "repo_pages"):
        spec = importlib.util.spec_from_file_location(ext, REPO / "docs" / "_ext" / f"{ext}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        made.add(module.PAGE.resolve())
    return made
