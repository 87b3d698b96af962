"""The core keeps no module state: what a caller keeps between calls (a
deck's cases, the channels last read) is in a handle of its own
(fortran/case/mlid_handles.f90).  Decks read and run from several threads at
once give exactly what each gives read and run alone, and a deck read after
another leaves the first one's cases as they were.  The routines that
released the GIL before still do."""

import re
import threading
from pathlib import Path

import pytest

import mlid
import mlid._bridge
from mlid.cli.deck import case_json, run_cases

from conftest import REPO

C8 = REPO / "cases" / "c8_short_period" / "c8.nml"


def deck_of(folder, n, nx):
    """A deck of n simulate cases of an nx-state model (titles that name the
    deck), then the C-8 deck's simulate and fit cases: what a reader that
    mixed two decks would get wrong."""
    cases = []
    for k in range(1, n + 1):
        f = ", ".join("-1.0" if i == j else "0.0" for i in range(nx) for j in range(nx))
        cases.append(f"&case title = 'nx {nx} case {k}', job = 'simulate' /\n"
                     f"&model kind = 'linear', nx = {nx}, nu = 1, ny = {nx},\n"
                     f"    f = {f}, g = {', '.join(['1.0'] * nx)},\n"
                     f"    h = {', '.join('1' if i == j else '0' for i in range(nx) for j in range(nx))} /\n"
                     f"&simulate out = 'sim{k}.dat', t_end = {0.1 * k:.1f}, dt = 0.05, seed = {k},\n"
                     f"    input_shape = 'doublet', amplitude = 0.1 /\n")
    folder.mkdir(parents=True, exist_ok=True)
    deck = folder / "deck.nml"
    deck.write_text("\n".join(cases) + "\n" + C8.read_text())
    return deck


def summary(cases):
    return [(c.title, c.job, c.model.nx if c.model is not None else None) for c in cases]


def outputs(deck):
    """Every case of deck run in order: its JSON text and report."""
    return ran(mlid.read_deck(deck))


def ran(cases):
    return [(case_json(case, out, error),
             result.report() if result is not None else getattr(out, "report", ""))
            for case, out, result, error in run_cases(cases)]


def test_a_deck_read_after_another_leaves_its_cases_alone(tmp_path):
    deck_a = deck_of(tmp_path / "a", 30, 2)
    alone = outputs(deck_a)
    a = mlid.read_deck(deck_a)
    b = mlid.read_deck(deck_of(tmp_path / "b", 3, 5))
    assert [c.title for c in a[:30]] == [f"nx 2 case {k}" for k in range(1, 31)]
    assert summary(b)[0] == ("nx 5 case 1", "simulate", 5)
    # the first deck's cases, run after the second was read, run as its own
    assert ran(a) == alone
    assert not (tmp_path / "b" / "sim1.dat").exists()


def test_decks_read_and_run_from_threads_give_the_serial_results(tmp_path):
    nthreads, rounds = 4, 3
    folders = [tmp_path / f"t{i}" for i in range(nthreads)]
    decks = [deck_of(f, 12 + 6 * i, 2 + i % 3) for i, f in enumerate(folders)]
    serial = {}
    for d in decks:
        serial[d] = (summary(mlid.read_deck(d)), outputs(d))
        for p in d.parent.glob("*.dat"):
            p.unlink()
    got, errors = {d: [] for d in decks}, []
    start = threading.Barrier(nthreads)

    def work(d):
        try:
            start.wait()
            for _ in range(rounds):
                got[d].append((summary(mlid.read_deck(d)), outputs(d)))
        except Exception as exc:       # reported below, in the main thread
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(d,)) for d in decks]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    for d in decks:
        assert len(got[d]) == rounds
        for run in got[d]:
            assert run[0] == serial[d][0]
            assert run[1] == serial[d][1]


def test_no_handle_is_refused_in_words():
    api = mlid._bridge.api
    *_, status, msg = api.mlid_deck_case_run(0, 1, 0)
    assert status != 0 and b"no such case (or not a live handle)" in msg
    nt, status, msg = api.mlid_deck_case_record(0, 1, 1, 0)
    assert status != 0 and nt == 0 and b"not a live handle" in msg


BUILT = REPO / "build" / "python" / "mlid" / "_coremodule.c"


@pytest.mark.skipif(not BUILT.is_file(), reason="no meson build beside the checkout")
def test_the_numerical_routines_still_release_the_gil():
    """f2py_threadsafe.py's routines: their wrappers let other threads run."""
    text = BUILT.read_text()
    for name in ("mlid_fit", "mlid_evaluate", "mlid_simulate", "mlid_monte_carlo"):
        head = re.search(rf"static PyObject \*f2py_rout__core_mlid_api_[a-z]+_{name}\(", text)
        assert head, name
        body = text[head.start():text.index("\n}\n", head.start())]
        assert "Py_BEGIN_ALLOW_THREADS" in body, name


def test_a_deck_case_fit_is_given_the_gil_hooks():
    """A deck case's run releases the GIL while it fits, as mlid_fit does:
    the flat interface hands the job runner (mlid_run's around_t) the
    extension's hooks (python/mlid/_gil.c), and every deck case run in these
    tests goes through them.  That other
    threads then run is measured, not tested (benchmarks/bench_deck_threads.py:
    two threads' deck fits 1.9 times as fast as one after another, 0.9 without
    the hooks)."""
    source = REPO / "fortran" / "api" / "mlid_api_deck.f90"
    if not source.is_file():
        pytest.skip("no source tree beside the tests")
    assert "around_t(gil_release, gil_restore)" in source.read_text()
    glue = (REPO / "python" / "mlid" / "_gil.c").read_text()
    assert "PyEval_SaveThread" in glue and "PyEval_RestoreThread" in glue
