"""
Online estimation: following a change as the data arrive
========================================================

A short-period model flown with a PRBS for 60 s, its control derivative M_δ halved at
30 s (noise σ 1e-3). The augmented-state extended Kalman filter (``mlid.online.ekf``)
with a random walk on the parameters, and Fourier-transform regression with a 10 s
memory (``mlid.online.ftr``, forgetting 0.998), each drawn by ``mlid.plots.online_history``:
every parameter against time with its ±2σ band, the batch fit of the second half
(dashed) and where the estimate settled. The deck's ``job = 'online'`` writes the same
history as a record (``cases/online``).
"""

import numpy as np
import matplotlib.pyplot as plt

import mlid
from mlid.design.signals import prbs

DT, N = 0.02, 3001
t = DT * np.arange(N)
de = prbs(7, 10, DT, N)
# M_delta halves at 30 s: the input reaches the pitch equation through two gains
u = np.column_stack([de * (t < 30), de * (t >= 30)])
F = [[-1.0, 1.0], [-4.0, -1.5]]
truth = mlid.LinearModel(F=F, G=[[0.1, 0.1], [-6.0, -3.0]], H=np.eye(2), r=[1e-6, 1e-6])
data, _ = mlid.simulate(truth, t, u, seed=2)
record = mlid.FlightData(t, de[:, None], data.y)

# the alpha equation known, the pitch equation's three derivatives from 50% off
start = mlid.LinearModel(F=[[-1.0, 1.0], [-2.0, -1.0]], G=[[0.1], [-3.0]], H=np.eye(2),
                         r=[1e-6, 1e-6], free=["f(2,1)", "f(2,2)", "g(2,1)"],
                         names={"f(2,1)": "M_alpha", "f(2,2)": "M_q", "g(2,1)": "M_delta"})
ekf = mlid.online.ekf(start, record, p0=10.0, q=[1e-7, 1e-7, 1e-4, 1e-4, 1e-3], r=[1e-6, 1e-6])
half = t >= 30                      # the second half's own initial state is fitted too
second = mlid.LinearModel(F=start.F, G=start.G, H=np.eye(2), r=[1e-6, 1e-6],
                          free=["f(2,1)", "f(2,2)", "g(2,1)", "x0(1)", "x0(2)"],
                          names={"f(2,1)": "M_alpha", "f(2,2)": "M_q", "g(2,1)": "M_delta"})
batch = mlid.fit(second, mlid.FlightData(t[half] - 30, de[half, None], data.y[half]))
print(ekf)
print("batch fit of the second half:", {n: round(v, 3) for n, v in
                                         zip(batch.names, np.asarray(batch.estimate).tolist())
                                         if n.startswith("M")})
mlid.plots.online_history(ekf, batch=batch)

ftr = mlid.online.ftr(t, data.y, de, np.arange(0.1, 2.0, 0.05), every=25, trim=0,
                      forgetting=0.998)
print(ftr)
mlid.plots.online_history(ftr, batch={"f(2,1)": -4.0, "f(2,2)": -1.5, "g(2,1)": -3.0})
plt.show()
