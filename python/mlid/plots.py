"""Plots of a fit: measured and estimated outputs, and the fit errors
(report Figs 5.7-5.8 style)."""

from pathlib import Path

from .files import atomic_savefig


def plot_fit(result, folder, stem):
    """Write FOLDER/STEM_fit.png and return its path."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    data, yhat = result.data, result.yhat
    ny = data.y.shape[1]
    fig, axes = plt.subplots(ny, 2, figsize=(11, 2.2 * ny + 0.6), sharex=True, squeeze=False)
    for i in range(ny):
        name = data.output_names[i]
        ax = axes[i, 0]
        ax.plot(data.t, data.y[:, i], ".", ms=2.5, color="0.45", label="measured")
        ax.plot(data.t, yhat[:, i], "-", lw=1.3, color="C0", label="estimated")
        ax.set_ylabel(name)
        ax = axes[i, 1]
        ax.plot(data.t, data.y[:, i] - yhat[:, i], "-", lw=0.8, color="C3")
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.set_ylabel(f"{name} error")
    axes[0, 0].legend(loc="best", fontsize=8)
    axes[0, 0].set_title("measured and estimated outputs")
    axes[0, 1].set_title("fit error")
    axes[-1, 0].set_xlabel("t [s]")
    axes[-1, 1].set_xlabel("t [s]")
    fig.tight_layout()
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{stem}_fit.png"
    atomic_savefig(fig, path, dpi=110)
    plt.close(fig)
    return path
