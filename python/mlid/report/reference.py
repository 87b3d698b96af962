"""Reference fits of the textbook software (the files under
../shared/data/refs: '#' header lines that write the model out, then one line
per parameter: name, estimate, Cramer-Rao sigma), read in one place, and a
fit compared with one parameter by parameter."""

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError


@dataclass
class Reference:
    """A reference fit: ``estimates`` {name: (value, sigma)}, det R, the
    diagonal of R and the peer's wall time in seconds (None where the
    header does not say)."""

    path: Path
    estimates: dict = field(default_factory=dict)
    det_r: float = None
    diag_r: np.ndarray = None
    seconds: float = None


def read_reference(path):
    """Read a reference file.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Reference

    Raises
    ------
    InputError
        If the file cannot be read or a parameter line is not 'name value sigma'.
    """
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except OSError as exc:
        raise InputError(f"reference {path}: {exc.strerror}") from None
    ref = Reference(path)
    for k, line in enumerate(lines, 1):
        if line.startswith("# Result:") and "det(R) =" in line:
            ref.det_r = float(line.split("det(R) =")[1].split()[0])
        elif line.startswith("#   diag(R)"):
            ref.diag_r = np.array([float(v) for v in line.split(":", 1)[1].split()])
        elif line.startswith("# Octave wall time:"):
            ref.seconds = float(line.split(":", 1)[1].split()[0])
        elif line.strip() and not line.startswith("#"):
            parts = line.split()
            try:
                ref.estimates[parts[0]] = (float(parts[1]), float(parts[2]))
            except (IndexError, ValueError):
                raise InputError(f"reference {path} line {k}: expected 'name value sigma', "
                                 f"got {line.strip()!r}") from None
    return ref


def compare(result, ref, names=None, shift=None):
    """A fit against a reference, parameter by parameter.

    Parameters
    ----------
    result : FitResult
    ref : Reference
    names : dict, optional
        Our label -> the reference's name, where they differ.
    shift : dict, optional
        Our label -> a constant added to the reference's value (a
        parameter stated as 1 + Z_q here and Z_q there).

    Returns
    -------
    dict
        ``rows`` (name, unit, ours, reference, (ours - ref)/sigma_ref,
        sigma/sigma_ref) and ``lines`` (the printed table and a summary with
        the largest difference, the sigma ratios and det R).

    Raises
    ------
    InputError
        If the reference has no value for a free parameter.
    """
    names, shift = names or {}, shift or {}
    units = getattr(result, "param_units", None) or [""] * len(result.names)
    rows = []
    for name, unit, value, sigma in zip(result.names, units, result.estimate, result.sigma):
        key = names.get(name, name)
        if key not in ref.estimates:
            raise InputError(f"reference {ref.path.name} has no value for {key}")
        ref_value, ref_sigma = ref.estimates[key]
        ref_value += shift.get(name, 0.0)
        rows.append((name, unit, float(value), ref_value, (value - ref_value) / ref_sigma,
                     sigma / ref_sigma))
    lines = [f"{'parameter':<9} {'unit':<11} {'ours':>16} {'reference':>16} {'diff/sigma':>11} "
             f"{'sigma ratio':>12}"]
    lines += [f"{n:<9} {u:<11} {v:16.9e} {r:16.9e} {z:11.2e} {s:12.5f}"
              for n, u, v, r, z, s in rows]
    z = np.array([row[4] for row in rows])
    s = np.array([row[5] for row in rows])
    summary = (f"largest |difference| {np.max(np.abs(z)):.2g} sigma; sigma ratios {s.min():.4f} "
               f"to {s.max():.4f}")
    if ref.det_r:
        summary += (f"; det R {result.det_r:.6e} against {ref.det_r:.6e} "
                    f"(relative {abs(result.det_r / ref.det_r - 1):.1e})")
    return {"rows": rows, "lines": lines + [summary]}
