"""The HL-10 case (cases/hl10_lateral): wrong signs unconstrained, a priori
weighting restores them at no loss of fit, the report names the confounding."""

import sys

import numpy as np

from conftest import REPO

sys.path.insert(0, str(REPO / "cases" / "hl10_lateral"))
import hl10  # noqa: E402


def test_hl10_remedies():
    data = hl10.record()
    results = hl10.fits(data)
    rows = {r["name"]: r for r in (hl10.summary(n, res) for n, res in results.items())}
    assert rows["unconstrained"]["wrong"]                      # the report's wrong signs
    assert not rows["a priori"]["wrong"] and not rows["bounds (signs)"]["wrong"]
    assert rows["a priori"]["dist"] < 0.3 < rows["unconstrained"]["dist"]
    assert rows["a priori"]["rms_fit"] < 1.01 * rows["unconstrained"]["rms_fit"]
    # the staged rank-deficient solution fixes the signs at no loss of fit (§5.3.6)
    staged = rows["rank-def., staged"]
    assert not staged["wrong"] and staged["rank"] < 13
    assert staged["rms_fit"] < 1.01 * rows["unconstrained"]["rms_fit"]
    assert staged["dist"] < 0.5 * rows["unconstrained"]["dist"]
    weak = results["unconstrained"].identifiability()
    assert all(n in weak[1] for n in ("N_dr", "N_r")) and "N_r/N_dr" in weak[2]


def test_hl10_prediction_and_model_size(tmp_path):
    results, rows, table, pred = hl10.run(plots=tmp_path)
    assert np.all(pred["rms_over_noise"] < 2.0)
    assert min(table, key=lambda r: r["fpe"])["k"] < 13     # FPE prefers a smaller model
    assert (tmp_path / "hl10_model_size.png").exists()


def test_sensitivity_norms_make_up_the_information():
    """With R diagonal, the squared norms summed over the outputs are the
    diagonal of the information matrix; the confounded pair has near-equal rows."""
    res = hl10.fits(hl10.record())["unconstrained"]
    s = res.sensitivity_norms()
    assert s.shape == (5, 13)
    np.testing.assert_allclose(np.sum(s**2, axis=0), np.diag(res.information), rtol=1e-9)
    k, j = res.names.index("N_r"), res.names.index("N_dr")
    np.testing.assert_allclose(s[:, k], s[:, j], rtol=0.05)
    assert len(res.sensitivity_table()) == 2 + 13
