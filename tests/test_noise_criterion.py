"""The two criteria for the measurement noise of filter error (issue 15
item 2): exact ML (r parameters like any other) and the innovations
criterion (r set after each Newton step to what the innovations leave,
R = S - C P C', at least a floor).  Checked against each other where both
hold (noisy outputs), against the truth on noise-free outputs, and through
both front ends."""

import json
import re
import warnings

import numpy as np
import pytest

import mlid
from conftest import run_both
from test_filter_error import BODY, gust_model, record

FREE = BODY + ["f(3,3)", "q(1)"]
OPTS = {"method": "filter_error"}


def fit(model, data, **opts):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = mlid.fit(model, data, **OPTS, **opts)
    return res, [str(w.message) for w in caught]


@pytest.mark.parametrize("steady", [True, False])
def test_innovations_criterion_agrees_with_exact_ml_on_noisy_outputs(steady):
    """Outputs with measurement noise (r = 1e-3, 2e-3), 300 samples: the
    relaxation's fixed point is close to the exact likelihood's maximum, so
    the two fits agree to a small fraction of the Cramer-Rao sigma (measured:
    below 0.05 sigma), and R to a fraction of exact ML's sigma of r."""
    data = record(gust_model(q=0.05), seed=5)
    exact, _ = fit(gust_model(FREE + ["r(1)", "r(2)"], q=0.02), data, steady_state=steady)
    innov, said = fit(gust_model(FREE, q=0.02), data, steady_state=steady,
                      noise_criterion="innovations")
    assert exact.converged and innov.converged
    assert not any("noise-free" in s for s in said)
    nf = len(FREE)
    dev = np.abs(innov.estimate - exact.estimate[:nf]) / exact.sigma[:nf]
    assert dev.max() < 0.2, dict(zip(FREE, dev))
    r_dev = np.abs(innov.r_innovations - exact.estimate[nf:]) / exact.sigma[nf:]
    assert r_dev.max() < 0.5, r_dev
    assert np.allclose(innov.r_innovations, innov.model.r)
    assert exact.r_innovations is None


def test_innovations_criterion_on_noise_free_outputs():
    """No measurement noise at all: exact ML with R free has no maximum, the
    innovations criterion converges, recovers the truth within 3 sigma and
    warns that both outputs look noise-free (their R within 2 sqrt(2/N) of
    the mean squared innovation)."""
    truth = gust_model(q=0.05, r=(1e-14, 1e-14))
    data = record(truth, seed=5)
    res, said = fit(gust_model(FREE, q=0.02, r=(1e-4, 1e-4)), data, steady_state=True,
                    noise_criterion="innovations")
    assert res.converged
    assert any("r(1), r(2) within sampling error of zero" in s for s in said), said
    limit = 2 * np.sqrt(2 / data.nt) * np.diag(res.rhat)
    assert np.all(res.r_innovations < limit)
    tv = {"f(1,1)": -1.0, "f(1,2)": -3.0, "f(2,2)": -0.8, "g(1,1)": 2.0, "f(3,3)": -1.5}
    for name, est, sd in zip(res.names, res.estimate, res.sigma):
        if name in tv:
            assert abs(est - tv[name]) < 3 * sd, (name, est, sd)


def test_exact_ml_with_r_free_names_the_noise_free_outputs():
    data = record(gust_model(q=0.05, r=(1e-14, 1e-14)), seed=5)
    res, _ = fit(gust_model(FREE + ["r(1)", "r(2)"], q=0.02, r=(1e-4, 1e-4)), data,
                 steady_state=True)
    assert not res.converged
    assert "r(2) look noise-free" in res.message
    assert "fix those r at a floor or use noise_criterion = 'innovations'" in res.message


def test_innovations_criterion_refusals():
    data = record(gust_model(q=0.05), seed=5)
    with pytest.raises(mlid.MlidError, match=r"r\(1\) is free, but with noise_criterion"):
        mlid.fit(gust_model(FREE + ["r(1)"]), data, **OPTS, noise_criterion="innovations")
    with pytest.raises(mlid.MlidError, match="is for filter error"):
        mlid.fit(gust_model(BODY), data, method="output_error", noise_criterion="innovations")
    with pytest.raises(mlid.MlidError, match="noise_criterion must be one of exact innovations"):
        mlid.fit(gust_model(FREE), data, **OPTS, noise_criterion="moments")


DECK = """&case title = 'gust: simulate', job = 'simulate' /
&model kind = 'linear', nx = 3, nu = 1, ny = 2, nw = 1,
    f = -1.0, -3.0, -3.0,  0.4, -0.8, -0.8,  0.0, 0.0, -1.5,
    g = 2.0, 0.5, 0.0,
    h = 1, 0, 0,  0, 1, 1,
    gamma = 0, 0, 1, q = 0.05, r = 1e-14, 1e-14 /
&simulate out = 'gust.dat', t_end = 15.0, dt = 0.05, seed = 5,
    input_shape = '3211', amplitude = 1.0, t_start = 0.5, pulse_width = 0.3 /

&case title = 'gust: innovations criterion', job = 'estimate' /
&model kind = 'linear', nx = 3, nu = 1, ny = 2, nw = 1,
    f = -1.2, -2.4, -2.4,  0.4, -0.6, -0.6,  0.0, 0.0, -2.0,
    g = 1.6, 0.5, 0.0,
    h = 1, 0, 0,  0, 1, 1,
    gamma = 0, 0, 1, q = 0.02, r = 1e-4, 1e-4,
    free = 'f(1,1)', 'f(1,2)', 'f(2,2)', 'g(1,1)', 'f(3,3)', 'q(1)',
    tie = 'f(1,3) = f(1,2)', 'f(2,3) = f(2,2)' /
&data file = 'gust.dat', time_col = 1, input_cols = 2, output_cols = 3, 4 /
&estimate method = 'filter_error', steady_state = .true., noise_criterion = 'innovations' /
"""


def test_both_front_ends_run_the_innovations_criterion(tmp_path):
    deck = tmp_path / "nc.nml"
    deck.write_text(DECK)
    py, fo = run_both(deck, "--json", str(tmp_path / "{exe}.json"), cwd=tmp_path)
    assert py.returncode == fo.returncode == 0, py.stderr + fo.stderr
    assert py.stdout == fo.stdout
    assert py.stderr.replace("mlid: ", "mlid-batch: ") == fo.stderr
    assert "r(1), r(2) within sampling error of zero" in fo.stderr
    assert " R diagonal (from the innovations)" in fo.stdout
    a, b = (json.loads((tmp_path / f"{e}.json").read_text()) for e in ("mlid", "mlid-batch"))
    assert a == b
    fitted = a[1]
    assert len(fitted["R_innovations"]) == 2


def test_dhc2_case_prints_its_readme(capsys):
    """cases/dhc2_turbulence: both remedies converge to the truth (every
    error within 3 sigma, the process noise against the realised), and the
    README's rows are what the script prints."""
    import importlib.util
    from pathlib import Path
    folder = Path(__file__).resolve().parent.parent / "cases" / "dhc2_turbulence"
    spec = importlib.util.spec_from_file_location("dhc2", folder / "dhc2.py")
    dhc2 = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(dhc2)
    res = dhc2.main([])
    out = capsys.readouterr().out
    assert res.converged
    worst = out.split("largest |error|/sigma:")[1].split("\n")[0]
    values = [float(v) for v in re.findall(r" (\d+\.\d+)(?:,|$)", worst)]
    assert len(values) == 2 and max(values) < 3.0, worst
    readme = (folder / "README.md").read_text()
    for row in ("sigma_p", "sigma_r", "L_r", "b_rdot"):
        printed = next(line for line in out.splitlines() if line.split()[:1] == [row])
        numbers = printed.replace("|", " ").split()[2:]
        for est, sd, z in zip(numbers[0::3], numbers[1::3], numbers[2::3]):
            assert f"{est.replace('-', '−')} ± {sd}" in readme, (row, est, sd)
