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
    weak = results["unconstrained"].identifiability()
    assert all(n in weak[1] for n in ("N_dr", "N_r")) and "N_r/N_dr" in weak[2]


def test_hl10_prediction_and_model_size(tmp_path):
    results, rows, table, pred = hl10.run(plots=tmp_path)
    assert np.all(pred["rms_over_noise"] < 2.0)
    assert min(table, key=lambda r: r["fpe"])["k"] < 13     # FPE prefers a smaller model
    assert (tmp_path / "hl10_model_size.png").exists()
