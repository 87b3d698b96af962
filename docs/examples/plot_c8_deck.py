"""
C-8 short period from a deck
============================

The deck ``cases/c8_short_period/c8.nml`` has two cases: the first simulates a doublet
record of the C-8 short period from the values of NASA CR-2200 §8.2.1, the second fits the
five short-period derivatives to it by output error from start values 30–50 % off. Python's
``mlid.run_deck`` runs it through the core's job runner, as ``mlid run`` and ``mlid-batch``
do; here it runs in a scratch folder, so that the record it writes stays out of the
repository.
"""

import shutil
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import mlid
from mlid.report import plots

from _records import CASES

work = Path(tempfile.mkdtemp())
shutil.copy(CASES / "c8_short_period" / "c8.nml", work)
(simulate, _, _, error1), (estimate, _, res, error2) = mlid.run_deck(work / "c8.nml")
assert error1 is None and error2 is None, (error1, error2)

# %%
# The printed report: start, estimate and Cramér-Rao σ of each parameter, the cost and R̂.
print(res.report())

# %%
# The estimates against the truth of case 1, in Cramér-Rao σ.
truth, z = res.against_truth(simulate.model)
for name, t, e, s in zip(res.params.index, truth, res.estimate, z):
    print(f"{name:8s} truth {t:9.4f}  estimate {e:9.4f}  (estimate - truth)/sigma {s:6.2f}")

# %%
# The fit: measured and model outputs, the residuals and the estimates.
fig = plots.fit_overview(res, title=f"cases/c8_short_period/c8.nml, case 2: {estimate.title}")
plt.show()

# %%
# What is the model missing? The discrepancy workflow tries a library of effects (sensor
# biases, scale factors and lags, input delays, missing derivatives) on the last third of the
# record, held out from their fits. The record was simulated from this very model, so each is
# rejected, and the residuals' figure is the same before and after.
d = mlid.diagnose(res.start_model, res.data, progress=False)
print(d.report().splitlines()[1])
d.figure()
plt.show()
shutil.rmtree(work)
