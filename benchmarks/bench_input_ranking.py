"""Which input to fly (issue 43): the ranking of 6 candidate inputs ('optimal',
'doublet', '3211', 'multisine', 'sweep', 'prbs') on the ATTAS lateral model,
target <= 50 ms, side by side with a straightforward scipy/numpy
implementation of the same table.

The model: cases/attas_lateral/attas_lat.nml's F and G (x = p, r; inputs
aileron and rudder, the sideslip input left out: it is flown by neither),
outputs p and r (H = I; the deck's other outputs carry a feedthrough D that
the design model has not), noise 0.1 deg/s on each per sample of 0.04 s
(R = r dt, eq. 7.11; ours, it sets no time), the eight unknowns Lp, Lr, Lda,
Ldr, Np, Nr, Nda, Ndr; T = 20 s on 100 cells of 0.2 s (the fastest mode, 3.5
rad/s, has 9 cells a time constant), energy 20; then on 200 cells of 0.1 s.

The peer takes the library's five signals ready-made (as the core scaled them:
the core's time includes making them, the multisine's 1,000 phase steps among
it), builds the weighted-trace operator on the cells from the exact pulse
response of the augmented system (scipy.linalg.expm, four substeps a cell,
Simpson's rule, as the core) and takes its leading eigenvector (eigh) as the
optimal input, then per candidate the sensitivities, M, det, trace, sigma
and the peak and rms of the states and outputs.  Its table is printed against
the core's (largest relative difference of sigma).

    python benchmarks/bench_input_ranking.py [rounds]
"""

import sys

import numpy as np
from scipy.linalg import eigh, expm

import mlid
from timing import interleaved_medians

F = np.array([[-3.53744, 0.475534], [-0.086939, -0.169526]])
G = np.array([[-4.93279, 0.73334], [-0.192049, -0.74855]])
H = np.eye(2)
DT_SAMPLE = 0.04
R = np.diag([np.radians(0.1) ** 2] * 2) * DT_SAMPLE
UNKNOWNS = ["f(1,1)", "f(1,2)", "g(1,1)", "g(1,2)", "f(2,1)", "f(2,2)", "g(2,1)", "g(2,2)"]
NAMES = ["Lp", "Lr", "Lda", "Ldr", "Np", "Nr", "Nda", "Ndr"]
T, ENERGY, NS = 20.0, 20.0, 4
CANDIDATES = ["optimal", "doublet", "3211", "multisine", "sweep", "prbs"]


def augmented():
    """x_A = [x; dx/dtheta_i], its F_A, G_A and the output sensitivities' H_A."""
    nx, nu, m = F.shape[0], G.shape[1], len(UNKNOWNS)
    fa, ga = np.zeros(((m + 1) * nx,) * 2), np.zeros(((m + 1) * nx, nu))
    ha = np.zeros((m * H.shape[0], (m + 1) * nx))
    fa[:nx, :nx], ga[:nx] = F, G
    for i, name in enumerate(UNKNOWNS):
        a, b = (int(v) - 1 for v in name[2:-1].split(","))
        o = (i + 1) * nx
        fa[o:o + nx, o:o + nx] = F
        if name[0] == "f":
            fa[o + a, b] = 1.0
        else:
            ga[o + a, b] = 1.0
        ha[i * H.shape[0]:(i + 1) * H.shape[0], o:o + nx] = H
    return fa, ga, ha


def peer(library_u, cells):
    """The table by scipy/numpy: the optimal input and, for it and each
    ready-made library input, M, det, trace, sigma, state and output peak
    and rms."""
    fa, ga, ha = augmented()
    na, nu, m, ny = len(fa), ga.shape[1], len(UNKNOWNS), H.shape[0]
    h = T / cells / NS
    e = expm(np.block([[fa, ga], [np.zeros((nu, na + nu))]]) * h)
    phi, gam = e[:na, :na], e[:na, na:]
    k = cells * NS
    w = np.full(k + 1, 2.0)
    w[1::2], w[0], w[-1] = 4.0, 1.0, 1.0
    w *= h / 3
    wr = np.kron(np.eye(m), np.linalg.inv(R))

    def states(u):                       # u (cells, nu) held: x_A at every substep
        x = np.zeros((k + 1, na))
        for j in range(k):
            x[j + 1] = phi @ x[j] + gam @ u[j // NS]
        return x

    # the operator: the pulse response of cell 0 shifted to each cell (the model is LTI)
    cols = []
    for j in range(nu):
        pulse = np.zeros((cells, nu))
        pulse[0, j] = 1.0
        cols.append(states(pulse) @ ha.T)                 # (k+1, m ny)
    big = np.zeros((k + 1, m * ny, cells * nu))
    for c in range(cells):
        for j in range(nu):
            big[c * NS:, :, c * nu + j] = cols[j][:k + 1 - c * NS]
    q = np.einsum("k,kai,ab,kbj->ij", w, big, wr, big, optimize=True)
    _, vec = eigh(q, subset_by_index=[cells * nu - 1, cells * nu - 1])
    opt = vec[:, 0].reshape(cells, nu)
    opt *= np.sqrt(ENERGY / (np.sum(opt ** 2) * T / cells)) * np.sign(opt[0].sum())
    table = {}
    for name, u in [("optimal", opt)] + list(library_u.items()):
        x = states(u)
        ys = x @ ha.T
        s = ys.reshape(-1, m, ny)
        M = np.einsum("k,kia,ab,kjb->ij", w, s, np.linalg.inv(R), s, optimize=True)
        inv = np.linalg.inv(M)
        xs, yo = x[:, :F.shape[0]], x[:, :F.shape[0]] @ H.T
        table[name] = dict(det=np.linalg.det(M), trace=np.trace(M),
                           sigma=np.sqrt(np.diag(inv)), x_peak=np.abs(xs).max(0),
                           x_rms=np.sqrt(w @ xs ** 2 / T), y_peak=np.abs(yo).max(0),
                           y_rms=np.sqrt(w @ yo ** 2 / T))
    return table


def main():
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    d = mlid.InputDesign(F, G, H, R, UNKNOWNS)
    for cells in (100, 200):
        ours = d.rank_inputs(T, energy=ENERGY, cells=cells, candidates=CANDIDATES)
        if cells == 100:
            print(ours)
        library = {n: ours.u[k] for k, n in enumerate(ours.names) if n != "optimal"}
        theirs = peer(library, cells)
        worst = max(np.max(np.abs(theirs[n]["sigma"] / ours.sigma[k] - 1))
                    for k, n in enumerate(ours.names))
        order = sorted(theirs, key=lambda n: -theirs[n]["det"])
        print(f"peer's ranking: {', '.join(order)} (ours: {', '.join(ours.names)}); "
              f"largest relative difference of sigma {worst:.1e}")
        t_ours, t_peer = interleaved_medians(
            [lambda: d.rank_inputs(T, energy=ENERGY, cells=cells, candidates=CANDIDATES),
             lambda: peer(library, cells)], rounds, 3)
        print(f"ATTAS lateral, 8 unknowns, 2 inputs, {len(CANDIDATES)} candidates on {cells} "
              f"cells of {T / cells:g} s: ours {1e3 * t_ours:.1f} ms (target <= 50 ms: "
              f"{'met' if t_ours <= 0.05 else 'NOT met'}), scipy/numpy {1e3 * t_peer:.1f} ms, "
              f"ratio {t_peer / t_ours:.1f}x")


if __name__ == "__main__":
    main()
