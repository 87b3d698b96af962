"""Model-size comparison and prediction checks (report §5.3.5, §5.2.8)."""

from pathlib import Path

import numpy as np

from ..data.flight_data import FlightData
from ..design.simulate import simulate
from ..errors import guarded
from ..files import atomic_savefig


@guarded
def fpe(result):
    """Akaike's final-prediction-error corrected cost (N-k)/(N+k) ln|R| of a
    fit with R estimated (report §5.3.5): lower is better, and unlike the
    cost it does not fall just because parameters are added.

    Parameters
    ----------
    result : FitResult
        N its samples, k its free parameters, R its R-hat.

    Returns
    -------
    float
    """
    n, k = result.data.nt, len(result.names)
    return (n - k) / (n + k) * float(np.linalg.slogdet(result.rhat)[1])


@guarded
def compare_models(results, labels=None, plot=None):
    """A table (and a Fig. 5.18-style plot) of fits with different free sets.

    Parameters
    ----------
    results : list of FitResult
        Fits of the same record.
    labels : list of str, optional
        One per fit (default 'fit 1', 'fit 2', ...).
    plot : str or Path, optional
        Where to write the plot of FPE and ln|R| against k (PNG, whole or
        not at all).

    Returns
    -------
    list of dict
        Per fit, fewest parameters first: ``label``, ``k``, ``cost``,
        ``ln_det_R`` and ``fpe``.
    """
    labels = labels or [f"fit {i + 1}" for i in range(len(results))]
    rows = sorted(({"label": lab, "k": len(r.names), "cost": r.cost,
                    "ln_det_R": float(np.linalg.slogdet(r.rhat)[1]), "fpe": fpe(r)}
                   for lab, r in zip(labels, results)), key=lambda row: row["k"])
    if plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(6, 3.6))
        ax.plot([r["k"] for r in rows], [r["fpe"] for r in rows], "o-", label="FPE (N-k)/(N+k) ln|R|")
        ax.plot([r["k"] for r in rows], [r["ln_det_R"] for r in rows], "s--", color="0.5",
                label="ln|R| (fit error)")
        for r in rows:
            ax.annotate(r["label"], (r["k"], r["fpe"]), fontsize=7, xytext=(3, 3),
                        textcoords="offset points")
        ax.set_xlabel("number of parameters k")
        ax.set_ylabel("criterion")
        ax.set_title("model size: prediction error vs fit error (report Fig. 5.18)")
        ax.legend(fontsize=8)
        fig.tight_layout()
        Path(plot).parent.mkdir(parents=True, exist_ok=True)
        atomic_savefig(fig, plot, dpi=110)
        plt.close(fig)
    return rows


@guarded
def predict(result, data, start):
    """Prediction check (report §5.2.8): the model fitted on the first part
    of a record run through the whole record, without noise.

    Parameters
    ----------
    result : FitResult
        The fit of the first part.
    data : FlightData
        The whole record.
    start : int
        The first sample (from 0) of the part predicted.

    Returns
    -------
    dict
        ``rms``, the prediction error RMS per output over samples start:;
        ``rms_over_noise``, it over sqrt(diag R-hat); ``prediction``, the
        predicted FlightData.

    Raises
    ------
    InputError
        data that does not fit the model.
    """
    predicted, _ = simulate(result.model, data.t, data.u)
    err = data.y[start:] - predicted.y[start:]
    rms = np.sqrt(np.mean(err**2, axis=0))
    noise = np.sqrt(np.diag(result.rhat))
    return {"rms": rms, "rms_over_noise": rms / noise,
            "prediction": FlightData(data.t, data.u, predicted.y, data.input_names,
                                     data.output_names)}


def plot_prediction(data, prediction, start, path):
    """Measured and predicted outputs, the fitted part shaded (Fig. 5.11 style)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    ny = data.y.shape[1]
    fig, axes = plt.subplots(ny, 1, figsize=(8, 1.8 * ny + 0.6), sharex=True, squeeze=False)
    for i, ax in enumerate(axes[:, 0]):
        ax.axvspan(data.t[0], data.t[start - 1], color="0.92")
        ax.plot(data.t, data.y[:, i], ".", ms=2.5, color="0.45", label="measured")
        ax.plot(data.t, prediction.y[:, i], "-", color="C0", lw=1.2, label="model")
        ax.set_ylabel(data.output_names[i])
    axes[0, 0].set_title("fitted on the shaded part, predicted on the rest")
    axes[0, 0].legend(fontsize=7)
    axes[-1, 0].set_xlabel("t [s]")
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    atomic_savefig(fig, path, dpi=110)
    plt.close(fig)
    return path
