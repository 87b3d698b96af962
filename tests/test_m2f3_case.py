"""The M2/F3 gust case tells the report's story (cases/m2f3_gusts)."""

import sys

import numpy as np

from conftest import REPO

sys.path.insert(0, str(REPO / "cases" / "m2f3_gusts"))
import m2f3  # noqa: E402


def _beyond_3_sigma(res, truth):
    known = [n in truth for n in res.names]
    z = np.array([abs(e - truth[n]) / s for n, e, s in zip(res.names, res.estimate, res.sigma)
                  if n in truth])
    return int(np.sum(z > 3)), sum(known)


def test_m2f3_story(tmp_path):
    out, data, states, gust = m2f3.run(plots=tmp_path)
    truth = out["truth"]
    oe, pb, fe, gm = (out[k] for k in ("output error", "perfect beta", "filter error",
                                       "gust model"))
    # (1) output error: residuals not white, several derivatives beyond 3 sigma
    assert not any(w["white"] for w in oe.whiteness())
    assert _beyond_3_sigma(oe, truth)[0] >= 4
    # (2) perfect beta: fits better than output error and recovers the gust
    assert pb.converged
    assert np.mean(np.abs(pb.residuals)) < np.mean(np.abs(oe.residuals[:, [0, 1, 3, 4]]))
    assert np.corrcoef(gust, states[:, 4])[0, 1] > 0.8
    z_gust = abs(gm.estimate[gm.names.index("a (gust)")] - truth["a (gust)"]) / \
        gm.sigma[gm.names.index("a (gust)")]
    assert z_gust < 3
    # (3) filter error: every derivative and the gust model within 3 sigma, white innovations
    assert fe.converged
    assert _beyond_3_sigma(fe, truth)[0] == 0
    assert all(w["white"] for w in fe.whiteness())
    assert (tmp_path / "m2f3_gust.png").exists()


def test_m2f3_remedies_with_sas():
    """Closed loop through roll and yaw dampers: filter error alone flips a
    control derivative; a priori weighting and the staged rank-deficient
    solution restore the signs at no loss of fit (report §5.3.4-5.3.6)."""
    import remedies
    rows = {n: remedies.summary(n, r) for n, r in remedies.fits(remedies.record()).items()}
    free = rows["unconstrained"]
    assert free["wrong"]
    for name in ("a priori", "rank-def., staged", "bounds (signs)"):
        assert not rows[name]["wrong"], name
        assert rows[name]["rms_fit"] < 1.01 * free["rms_fit"], name
    staged = rows["rank-def., staged"]
    assert staged["rank"] < staged["k"] and staged["dist"] < 0.25 * free["dist"]
