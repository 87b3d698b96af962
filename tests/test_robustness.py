"""Whatever goes wrong, one line and the rest goes on: the command line
(outputs checked before the first case, a failing plot, a broken pipe) and
the Python API (misuse raises only mlid errors, with the problem named)."""

import subprocess

import numpy as np
import pytest

import mlid
from mlid.design.signals import input_signal
from conftest import BIN
from test_decks import SIM, SMALL


def _deck(tmp_path, middle):
    deck = tmp_path / "batch.nml"
    deck.write_text(SIM + middle + SMALL.format(title="last", file="small.dat"))
    return deck


def test_outputs_are_tried_before_the_first_case(tmp_path):
    deck = _deck(tmp_path, "")
    for cmd in ([str(BIN / "mlid"), "run"], [str(BIN / "mlid-batch")]):
        run = subprocess.run(cmd + [str(deck), "--json", str(tmp_path / "no" / "out.json")],
                             capture_output=True, text=True)
        assert run.returncode == 1, run.stderr
        assert "case 1" not in run.stdout and not (tmp_path / "small.dat").exists()
        lines = run.stderr.strip().splitlines()
        assert len(lines) == 1 and "cannot write" in lines[0] and "out.json" in lines[0]
    (tmp_path / "plots").write_text("a file, not a folder")
    run = subprocess.run([str(BIN / "mlid"), "run", str(deck), "--plots", str(tmp_path / "plots")],
                         capture_output=True, text=True)
    assert run.returncode == 1 and "case 1" not in run.stdout
    assert run.stderr.count("\n") == 1 and "--plots" in run.stderr


def test_a_failing_plot_is_one_line_and_the_batch_goes_on(tmp_path):
    deck = _deck(tmp_path, SMALL.format(title="middle", file="small.dat"))
    plots = tmp_path / "plots"
    (plots / "case2_fit.png").mkdir(parents=True)       # the plot cannot take its name
    run = subprocess.run([str(BIN / "mlid"), "run", str(deck), "--plots", str(plots), "--json",
                          str(tmp_path / "out.json")], capture_output=True, text=True)
    assert run.returncode == 1 and "Traceback" not in run.stderr
    errors = [ln for ln in run.stderr.splitlines() if ln.startswith("mlid:")]
    assert len(errors) == 1 and "case 2" in errors[0] and "plot" in errors[0]
    assert run.stdout.count("converged (") == 2 and (plots / "case3_fit.png").is_file()
    assert not list(plots.glob(".*.tmp"))               # no half-written plot left behind


def test_a_broken_pipe_ends_quietly(tmp_path):
    deck = _deck(tmp_path, SMALL.format(title="middle", file="small.dat"))
    proc = subprocess.Popen([str(BIN / "mlid"), "run", str(deck)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    proc.stdout.readline()
    proc.stdout.close()                                  # as `| head -1` does
    err = proc.stderr.read().decode()
    proc.wait(timeout=120)
    assert "Traceback" not in err and "Error" not in err, err
    assert proc.returncode in (0, 141)


@pytest.fixture(scope="module")
def model():
    return mlid.LinearModel([[-1.0, 0.5], [-0.8, -2.0]], [[1.0], [0.3]], np.eye(2),
                            free=["f(1,1)", "g(1,1)"])


@pytest.fixture(scope="module")
def data(model):
    t = np.arange(101) * 0.02
    u = input_signal("3211", 1.0, 0.2, 0.2, 0.02, t.size).reshape(-1, 1)
    return mlid.simulate(model, t, u, noise_std=[0.01, 0.01], seed=3)[0]


def _misuses(model, data):
    t, u, y = data.t, data.u, data.y
    return {
        "fit: model None": lambda: mlid.fit(None, data),
        "fit: model a path": lambda: mlid.fit("model.nml", data),
        "fit: data None": lambda: mlid.fit(model, None),
        "fit: data a path": lambda: mlid.fit(model, "flight.dat"),
        "fit: data an array": lambda: mlid.fit(model, y),
        "fit: empty list": lambda: mlid.fit(model, []),
        "fit: unknown option": lambda: mlid.fit(model, data, tolerance=1.0),
        "fit: max_iter text": lambda: mlid.fit(model, data, max_iter="many"),
        "fit: max_iter huge": lambda: mlid.fit(model, data, max_iter=2**40),
        "fit: max_iter beyond the limit": lambda: mlid.fit(model, data, max_iter=2**31 - 1),
        "fit: unknown method": lambda: mlid.fit(model, data, method="ricatti"),
        "fit: prior of a fixed parameter": lambda: mlid.fit(model, data, prior_weight={"h(1,1)": 1}),
        "FlightData: y given ny x nt": lambda: mlid.FlightData(t, u, y.T),
        "FlightData: u given nu x nt": lambda: mlid.FlightData(t, u.T, y),
        "FlightData: t None": lambda: mlid.FlightData(None, u, y),
        "FlightData: text": lambda: mlid.FlightData(t, "u", y),
        "FlightData: complex": lambda: mlid.FlightData(t, u + 1j, y),
        "FlightData.load: None": lambda: mlid.FlightData.load(None, 1, [2], [3]),
        "FlightData.load: column 0": lambda: mlid.FlightData.load(__file__, 0, [2], [3]),
        "simulate: u transposed": lambda: mlid.simulate(model, t, u.T.repeat(2, axis=0)),
        "simulate: seed huge": lambda: mlid.simulate(model, t, u, seed=2**40),
        "simulate: seed a float": lambda: mlid.simulate(model, t, u, seed=1.5),
        "simulate: model None": lambda: mlid.simulate(None, t, u),
        "simulate: bad timing": lambda: mlid.simulate(model, t, u, timing="sideways"),
        "monte_carlo: runs 0": lambda: mlid.monte_carlo(model, model, t, u, runs=0),
        "monte_carlo: runs huge": lambda: mlid.monte_carlo(model, model, t, u, runs=2**40),
        "input_signal: unknown shape": lambda: input_signal("sine", 1, 0, 1, 0.1, 10),
        "input_signal: nt huge": lambda: input_signal("step", 1, 0, 1, 0.1, 2**40),
        "check_jacobians: x wrong size": lambda: mlid.check_jacobians(model, [0.0] * 5, [0.0]),
        "LinearModel: F None": lambda: mlid.LinearModel(None, [[1.0]], [[1.0]]),
        "LinearModel: free unknown": lambda: mlid.LinearModel(np.eye(2), [[1], [0]], np.eye(2),
                                                              free=["f(3,1)"]),
        "InputDesign: unknown solver": lambda: mlid.InputDesign(
            [[-1.0]], [[1.0]], [[1.0]], [[0.01]], ["f(1,1)"]).critical_length(1.0, "ricatti"),
        "read_deck: None": lambda: mlid.read_deck(None),
        "read_deck: a folder": lambda: mlid.read_deck("/"),
    }


def test_api_misuse_raises_only_mlid_errors(model, data):
    """Each misuse raises an MlidError subclass whose message names the
    problem (never AttributeError, f2py's shape check, KeyError, ...)."""
    cases = _misuses(model, data)
    assert len(cases) >= 25
    wrong = {}
    for name, call in cases.items():
        try:
            call()
            wrong[name] = "no error"
        except mlid.MlidError as exc:
            if not str(exc).strip():
                wrong[name] = "an empty message"
        except Exception as exc:                         # noqa: BLE001 - what the test is about
            wrong[name] = f"{type(exc).__name__}: {exc}"
    assert not wrong, wrong


def test_transposed_outputs_are_refused_with_the_shape_named(data):
    with pytest.raises(mlid.InputError, match=r"y has shape \(2, 101\); expected \(nt, ny\)"):
        mlid.FlightData(data.t, data.u, data.y.T)


@pytest.mark.parametrize("method", ["output_error", "filter_error"])
def test_a_gap_in_time_is_named_for_every_method(model, data, method):
    t = data.t.copy()
    t[60:] += 5.0                                        # two manoeuvres joined
    joined = mlid.FlightData(t, data.u, data.y)
    with pytest.raises(mlid.InputError, match=r"a gap in time from 1\.18 s to 6\.2 s at sample 61 "
                                              r".*split the record into manoeuvres"):
        mlid.fit(model, joined, method=method)


def test_json_strings_are_escaped_and_valid_utf8(tmp_path):
    """A title with a TAB and a latin-1 byte: both front ends write the same
    valid JSON (the byte replaced, the TAB escaped)."""
    import json

    deck = tmp_path / "d.nml"
    deck.write_bytes(SIM.replace("make data", "make\tdata \xe9t\xe9").encode("latin-1")
                     + SMALL.format(title="fit", file="small.dat").encode())
    for who in ("mlid", "mlid-batch"):
        cmd = [str(BIN / who)] + (["run"] if who == "mlid" else []) + [
            str(deck), "--json", str(tmp_path / f"{who}.json")]
        assert subprocess.run(cmd, capture_output=True).returncode == 0
    a, b = ((tmp_path / f"{w}.json").read_bytes() for w in ("mlid", "mlid-batch"))
    assert a == b
    assert json.loads(a.decode("utf-8"))[0]["title"] == "make\tdata \ufffdt\ufffd"


def test_parallel_runs_of_one_deck_agree(tmp_path):
    """Records are replaced whole: two runs of one deck at once never read
    each other's half-written record."""
    deck = _deck(tmp_path, "")
    runs = [subprocess.Popen([str(BIN / "mlid-batch"), str(deck), "--json",
                              str(tmp_path / f"{k}.json")], stdout=subprocess.DEVNULL)
            for k in range(2)]
    assert [p.wait(timeout=120) for p in runs] == [0, 0]
    import json
    a, b = (json.loads((tmp_path / f"{k}.json").read_text())[1]["estimate"] for k in range(2))
    assert a == b
