"""Batch decks: Fortran namelist groups, several cases stacked in one file.

The same rules as the Fortran reader (fortran/mlid_deck.f90), so that
``mlid run`` and ``mlid-batch`` read a deck identically: a case starts at
each line whose first word is ``&case``; '!' starts a comment outside
quotes; matrices are given row by row; relative file names are taken from
the deck's folder.  See README.md for every group and name.
"""

import math
import re
import warnings
from pathlib import Path

import f90nml
import numpy as np

from . import core
from .data import FlightData
from .errors import InputError, MlidError
from .model import CONSTANTS, LinearModel, LongitudinalModel, UserModel, X22Model

_REAL, _INT, _STR, _REALS, _INTS, _STRS = "real", "int", "str", "reals", "ints", "strs"
_BOOL = "bool"


def _schema():
    opts = core.default_options()
    return {
        "case": {"title": (_STR, ""), "job": (_STR, "")},
        "model": {
            "kind": (_STR, "linear"), "nx": (_INT, 0), "nu": (_INT, 0), "ny": (_INT, 0),
            "nw": (_INT, 0), "f": (_REALS, None), "g": (_REALS, None), "h": (_REALS, None),
            "d": (_REALS, None), "gamma": (_REALS, None), "k": (_REALS, None),
            "x0": (_REALS, None), "bias": (_REALS, None), "q": (_REALS, None), "r": (_REALS, None),
            "s": (_REALS, None), "free": (_STRS, []), "names": (_STRS, []),
            "tie": (_STRS, []), "input_hold": (_STR, "linear"),
            "cd_regressors": (_STRS, []), "cl_regressors": (_STRS, []),
            "cm_regressors": (_STRS, []), "cd": (_REALS, None), "cl": (_REALS, None),
            "cm": (_REALS, None), "constants": (_REALS, None), "p": (_REALS, None),
            "user_iconst": (_INTS, []), "user_rconst": (_REALS, []),
            "substeps": (_INT, 1), "state_names": (_STRS, []),
            "input_names": (_STRS, []), "output_names": (_STRS, []),
        },
        "data": {"file": (_STRS, []), "time_col": (_INT, 1), "input_cols": (_INTS, []),
                 "output_cols": (_INTS, []), "skip_rows": (_INT, 0)},
        "simulate": {"out": (_STR, ""), "t_end": (_REAL, 0.0), "dt": (_REAL, 0.0),
                     "seed": (_INT, 0), "noise_std": (_REALS, None),
                     "input_shape": (_STRS, []), "amplitude": (_REALS, None),
                     "t_start": (_REALS, None), "pulse_width": (_REALS, None)},
        "estimate": {"method": (_STR, "output_error"), "startup": (_STR, "none"),
                     "max_iter": (_INT, opts["max_iter"]),
                     "halvings": (_INT, opts["halvings"]), "noise": (_STR, "diagonal"),
                     "partials": (_BOOL, opts["partials"]),
                     "steady_state": (_BOOL, opts["steady_state"]),
                     "tol_cost": (_REAL, opts["tol_cost"]),
                     "tol_step": (_REAL, opts["tol_step"]), "tol_grad": (_REAL, opts["tol_grad"]),
                     "rcond": (_REAL, opts["rcond"]), "prior": (_REALS, None),
                     "prior_weight": (_REALS, None), "prior_decay": (_REAL, opts["prior_decay"]),
                     "rank_min": (_INT, opts["rank_min"]), "rank_max": (_INT, opts["rank_max"]),
                     "rank_rule": (_STR, opts["rank_rule"]),
                     "lower": (_REALS, None),
                     "upper": (_REALS, None)},
    }


class Case:
    """One case of a deck: what to run, or why it cannot run (``error``)."""

    def __init__(self, index, line, deck):
        self.index, self.line, self.deck = index, line, Path(deck)
        self.title, self.job, self.error = "", "", None
        self.model = None
        self.groups = {}

    def where(self):
        return f"{self.deck} case {self.index} (line {self.line}) '{self.title}'"

    # -- what the case needs to run ------------------------------------
    def record(self):
        """The FlightData of an estimate case, read from its data file; a list
        of them when the case names several files (several manoeuvres)."""
        d, m = self.groups["data"], self.groups["model"]
        records = [FlightData.load(self._path(f), d["time_col"], d["input_cols"],
                                   d["output_cols"], d["skip_rows"],
                                   input_names=m["input_names"] or None,
                                   output_names=m["output_names"] or None)
                   for f in d["file"] if f]
        return records[0] if len(records) == 1 else records

    def time_input(self):
        """Time base and inputs of a simulate case (shapes from the core)."""
        s = self.groups["simulate"]
        nt = int(math.floor(s["t_end"] / s["dt"] + 0.5)) + 1
        t = np.arange(nt) * s["dt"]
        u = np.zeros((nt, self.model.nu))
        for k, a in enumerate(s["amplitude"]):
            u[:, k] = core.input_signal(s["input_shape"][k], a, s["t_start"][k],
                                        s["pulse_width"][k], s["dt"], nt)
        return t, u

    def options(self):
        """Options for fit(): the &estimate group, with the per-free-parameter
        lists (order of &model free) turned into prior, prior_weight, bounds."""
        e = dict(self.groups.get("estimate", {}))
        free = [f for f in self.groups["model"]["free"] if f]
        lists = {k: [v for v in (e.pop(k) or [])] for k in ("prior", "prior_weight", "lower",
                                                             "upper")}
        for key, vals in lists.items():
            if len(vals) > len(free):
                raise InputError(f"group &estimate: prior, prior_weight, lower and upper take one "
                                 f"value per free parameter ({len(free)})")
        pick = {k: {f: v for f, v in zip(free, vals) if v is not None} for k, vals in lists.items()}
        if pick["prior"] or pick["prior_weight"]:
            e["prior"] = pick["prior"]
            e["prior_weight"] = pick["prior_weight"] if pick["prior_weight"] else None
        if pick["lower"] or pick["upper"]:
            e["bounds"] = {f: (pick["lower"].get(f), pick["upper"].get(f))
                           for f in set(pick["lower"]) | set(pick["upper"])}
        return e

    def _path(self, name):
        p = Path(name)
        return p if p.is_absolute() else self.deck.parent / p


def _strip_comment(line, mark="!"):
    quote = None
    for k, ch in enumerate(line):
        if quote:
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
        elif ch == mark:
            return line[:k]
    return line


def _first_word(line):
    words = re.split(r"[\s/,]+", line.strip(), maxsplit=1)
    return words[0].lower() if words else ""


def read_deck(path):
    """All cases of a deck.  A case that cannot run carries its ``error``;
    a deck that cannot be read at all raises InputError."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"file not found: {path}")
    lines = path.read_text().splitlines()
    starts = [k for k, ln in enumerate(lines) if _first_word(ln) == "&case"]
    if not starts:
        raise InputError(f"{path}: no &case group found (a deck is a sequence of cases, each "
                         "starting with &case)")
    for k in range(starts[0]):
        if _strip_comment(lines[k]).strip():
            raise InputError(f"{path} line {k + 1}: text before the first &case group")
    schema = _schema()
    cases = []
    for i, s in enumerate(starts):
        end = starts[i + 1] if i + 1 < len(starts) else len(lines)
        case = Case(i + 1, s + 1, path)
        try:
            _read_case(case, lines[s:end], s + 1, schema)
        except InputError as exc:
            case.error = str(exc)
        cases.append(case)
    return cases


def _group_line(block, line0, group):
    for k, ln in enumerate(block):
        if f"&{group}" in _strip_comment(ln).lower():
            return line0 + k
    return line0


def _read_case(case, block, line0, schema):
    text = [_strip_comment(ln) for ln in block]
    for k, ln in enumerate(text):
        for name in re.findall(r"&(\w*)", re.sub(r"'[^']*'|\"[^\"]*\"", "", ln)):
            if name.lower() not in schema:
                raise InputError(f"line {line0 + k}: unknown group &{name} (groups are &case, "
                                 "&model, &data, &simulate, &estimate)")
    try:
        # f90nml drops values it cannot place, with a warning: refuse rather than lose them
        # x(i) = a, b fills x(i), x(i+1) in Fortran; f90nml needs x(i:) for that
        body = re.sub(r"\b(\w+)\((\d+)\)(\s*=)", r"\1(\2:)\3", "\n".join(text))
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            nml = f90nml.reads(body + "\n")
    except UserWarning as exc:
        raise InputError(f"line {line0}: {str(exc).replace('f90nml: warning: ', '')}; "
                         "to give several values from an index write x(i:j) = ...") from None
    except Exception as exc:  # f90nml raises several types for bad syntax
        raise InputError(f"line {line0}: cannot parse the case: {exc}") from None
    groups = {}
    for name, spec in schema.items():
        if name not in nml:
            continue
        found = nml[name]
        if isinstance(found, list):
            raise InputError(f"group &{name} given twice in one case")
        where = f"group &{name} (line {_group_line(block, line0, name)})"
        values = {key: default for key, (_, default) in spec.items()}
        for key, value in found.items():
            if key not in spec:
                raise InputError(f"{where}: unknown name '{key}'")
            values[key] = _convert(where, key, spec[key][0], value,
                                   found.start_index.get(key, [1])[0] or 1)
        groups[name] = values
    case.groups = groups
    c = groups["case"]
    case.title, case.job = c["title"], c["job"].lower()
    if case.job not in ("estimate", "simulate"):
        raise InputError(f"group &case: job must be 'estimate' or 'simulate', got '{c['job']}'")
    if "model" not in groups:
        raise InputError(f"group &model is missing (job '{case.job}' needs it)")
    case.model = _model(groups["model"])
    if case.job == "estimate":
        _check_data(groups, case.model)
        e = groups.setdefault("estimate", {k: v for k, (_, v) in schema["estimate"].items()})
        e["noise"] = e["noise"].lower()
        e["method"] = e["method"].lower()
        e["startup"] = e["startup"].lower()
        e["rank_rule"] = e["rank_rule"].lower()
        if e["rank_rule"] not in ("iteration", "staged"):
            raise InputError(f"group &estimate: rank_rule must be 'iteration' or 'staged', "
                             f"got '{e['rank_rule']}'")
        if e["startup"] not in ("none", "equation_error"):
            raise InputError(f"group &estimate: startup must be 'none' or 'equation_error', "
                             f"got '{e['startup']}'")
        if e["method"] not in ("output_error", "filter_error"):
            raise InputError(f"group &estimate: method must be 'output_error' or 'filter_error', "
                             f"got '{e['method']}'")
        if e["noise"] not in ("diagonal", "full"):
            raise InputError(f"group &estimate: noise must be 'diagonal' or 'full', got "
                             f"'{e['noise']}'")
    else:
        _check_simulate(groups, case.model)


def _convert(where, key, kind, value, start):
    values = value if isinstance(value, list) else [value]
    if kind in (_REALS, _INTS, _STRS):
        values = [None] * (start - 1) + values
    elif isinstance(value, list):
        raise InputError(f"{where}: '{key}' takes one value, got {len(value)}")
    base = {_REAL: (int, float), _REALS: (int, float), _INT: (int,), _INTS: (int,),
            _STR: (str,), _STRS: (str,), _BOOL: (bool,)}[kind]
    for v in values:
        if v is not None and (isinstance(v, bool) != (kind == _BOOL) or not isinstance(v, base)):
            raise InputError(f"{where}: bad value {v!r} for '{key}'")
    if kind in (_REAL, _INT, _STR, _BOOL):
        return values[0]
    return values


def _given(values, n, key, shape, required):
    """Values of a deck array that must have exactly n entries."""
    vals = values or []
    given = [v for v in vals if v is not None]
    if not given and not required:
        return None
    if len(given) != n or any(v is None for v in vals[:n]):
        raise InputError(f"group &model: {key} has {len(given)} values, {key} is {shape} and "
                         f"needs {n}" + (" (row by row)" if "x" in shape else ""))
    return np.array(vals[:n], dtype=float)


def _free_and_labels(m):
    """The &model free list and its labels (names), blanks dropped."""
    free = [f for f in m["free"] if f]
    labels = [n for n in m["names"] if n]
    if len(labels) > len(free):
        raise InputError("group &model: more names than free parameters")
    return free, labels


def _labelled(m, build):
    """The model build(free) makes from the &model free list, its free
    parameters given their deck labels (the rest keep theirs); its errors
    named as the group's."""
    free, labels = _free_and_labels(m)
    try:
        model = build(free)
    except InputError as exc:
        text = str(exc)
        raise InputError(text if text.startswith("group &model") else f"group &model: {text}") \
            from None
    model.names.update({model.canonical_name(f): n for f, n in zip(free, labels)})
    return model


def _longitudinal(m):
    if any(v not in (0, w) for v, w in zip((m["nx"], m["nu"], m["ny"], m["nw"]), (4, 2, 7, 4))):
        raise InputError("group &model: a longitudinal model has nx, nu, ny, nw = 4, 2, 7, 4")
    regs = {key: [r for r in m[f"{key.lower()}_regressors"] if r] for key in ("CD", "CL", "Cm")}
    coeffs = {key: _given(m[key.lower()], len(regs[key]), key.lower(), str(len(regs[key])), True)
              for key in regs}
    consts = [v for v in (m["constants"] or []) if v is not None]
    if len(consts) != 9:
        raise InputError("group &model: constants needs 9 values: g, S/m, S cbar/Iy, lT/Iy, V0, "
                         "m, sigma_T, rho, cbar/2")
    return _labelled(m, lambda free: LongitudinalModel(
        regs, coeffs, dict(zip(CONSTANTS, consts)), x0=_given(m["x0"], 4, "x0", "4", False),
        bias=_given(m["bias"], 7, "bias", "7", False), r=_given(m["r"], 7, "r", "7", False),
        q=_given(m["q"], 4, "q", "4", False), S=_given(m["s"], 28, "s", "4x7", False),
        free=free, input_hold=m["input_hold"].lower(), substeps=m["substeps"]))


def _user(m):
    def build(free):
        model = UserModel([v for v in (m["p"] or []) if v is not None],
                          [v for v in m["user_iconst"] if v is not None],
                          [v for v in m["user_rconst"] if v is not None], free=free,
                          input_hold=m["input_hold"].lower(), substeps=m["substeps"])
        for key in ("x0", "bias", "r"):
            n = getattr(model, key).size
            given = _given(m[key], n, key, str(n), False)
            if given is not None:
                setattr(model, key, given)
        return model
    return _labelled(m, build)


def _x22(m):
    if any(v not in (0, w) for v, w in zip((m["nx"], m["nu"], m["ny"], m["nw"]), (4, 1, 7, 3))):
        raise InputError("group &model: the X-22 model has nx, nu, ny, nw = 4, 1, 7, 3")
    return _labelled(m, lambda free: X22Model(
        _given(m["p"], 23, "p", "23", True), x0=_given(m["x0"], 4, "x0", "4", False),
        bias=_given(m["bias"], 7, "bias", "7", False), q=_given(m["q"], 3, "q", "3", False),
        r=_given(m["r"], 7, "r", "7", False), S=_given(m["s"], 21, "s", "3x7", False),
        free=free, input_hold=m["input_hold"].lower(), substeps=m["substeps"]))


def _model(m):
    kind = m["kind"].lower()
    if kind == "longitudinal":
        return _longitudinal(m)
    if kind == "user":
        return _user(m)
    if kind == "x22":
        return _x22(m)
    if kind != "linear":
        raise InputError(f"group &model: unknown kind '{m['kind']}' (available: linear, "
                         "longitudinal, x22, user)")
    nx, nu, ny, nw = m["nx"], m["nu"], m["ny"], m["nw"]
    if not (1 <= nx <= 30 and 0 <= nu <= 10 and 1 <= ny <= 30 and 0 <= nw <= 10):
        raise InputError(f"group &model: nx, nu, ny, nw = {nx} {nu} {ny} {nw} out of range; "
                         "limits are 30 10 30 10")
    F = _given(m["f"], nx * nx, "f", f"{nx}x{nx}", True).reshape(nx, nx)
    G = _given(m["g"], nx * nu, "g", f"{nx}x{nu}", nu > 0)
    H = _given(m["h"], ny * nx, "h", f"{ny}x{nx}", True).reshape(ny, nx)
    D = _given(m["d"], ny * nu, "d", f"{ny}x{nu}", False)
    gamma = _given(m["gamma"], nx * nw, "gamma", f"{nx}x{nw}", nw > 0)
    K = _given(m["k"], nu * nx, "k", f"{nu}x{nx}", False)
    x0 = _given(m["x0"], nx, "x0", str(nx), False)
    bias = _given(m["bias"], ny, "bias", str(ny), False)
    q = _given(m["q"], nw, "q", str(nw), False)
    r = _given(m["r"], ny, "r", str(ny), False)
    S = _given(m["s"], nw * ny, "s", f"{nw}x{ny}", False)
    G = np.zeros((nx, nu)) if G is None else G.reshape(nx, nu)
    D = None if D is None else D.reshape(ny, nu)
    gamma = np.zeros((nx, nw)) if gamma is None else gamma.reshape(nx, nw)
    K = None if K is None else K.reshape(nu, nx)
    S = None if S is None else S.reshape(nw, ny)
    ties = {}
    for tie in m["tie"]:
        if not tie:
            continue
        if tie.count("=") != 1:
            raise InputError(f"group &model: tie '{tie}' must read 'a=b' with two parameters "
                             "that exist")
        a, b = tie.split("=")
        ties[a.strip()] = b.strip()
    if m["input_hold"].lower() not in ("linear", "zoh"):
        raise InputError(f"group &model: input_hold must be 'linear' or 'zoh', got "
                         f"'{m['input_hold']}'")
    return _labelled(m, lambda free: LinearModel(
        F, G, H, D, x0, bias, free=free, input_hold=m["input_hold"].lower(),
        substeps=m["substeps"], Gamma=gamma, q=q, r=r, S=S, ties=ties, K=K))


def _check_data(groups, model):
    if "data" not in groups:
        raise InputError("group &data is missing (job 'estimate' needs it)")
    d = groups["data"]
    d["input_cols"] = [c for c in d["input_cols"] if c]
    d["output_cols"] = [c for c in d["output_cols"] if c]
    d["file"] = [f for f in (d["file"] or []) if f]
    if not d["file"]:
        raise InputError("group &data: file is missing")
    if len(d["input_cols"]) != model.nu or len(d["output_cols"]) != model.ny:
        raise InputError(f"group &data: {len(d['input_cols'])} input_cols and "
                         f"{len(d['output_cols'])} output_cols given, the model has {model.nu} "
                         f"inputs and {model.ny} outputs")
    if min(d["input_cols"] + d["output_cols"] + [d["time_col"]]) < 1 or d["skip_rows"] < 0:
        raise InputError("group &data: column numbers must be >= 1 and skip_rows >= 0")


def _check_simulate(groups, model):
    if "simulate" not in groups:
        raise InputError("group &simulate is missing (job 'simulate' needs it)")
    s = groups["simulate"]
    s["noise_std"] = [v for v in (s["noise_std"] or []) if v is not None]
    s["amplitude"] = [v for v in (s["amplitude"] or []) if v is not None] or [0.0] * model.nu
    # one value serves every input; otherwise one per input
    def per_input(values, default):
        given = [v for v in (values or []) if v not in (None, "")] or [default]
        return given * model.nu if len(given) == 1 else given

    s["input_shape"] = [v.lower() for v in per_input(s["input_shape"], "none")]
    s["t_start"] = per_input(s["t_start"], 0.0)
    s["pulse_width"] = per_input(s["pulse_width"], 0.0)
    if not s["out"]:
        raise InputError("group &simulate: out (the data file to write) is missing")
    if not (s["dt"] > 0 and s["t_end"] > s["dt"]):
        raise InputError("group &simulate: need dt > 0 and t_end > dt")
    if s["noise_std"] and len(s["noise_std"]) != model.ny:
        raise InputError(f"group &simulate: noise_std has {len(s['noise_std'])} values, the "
                         f"model has {model.ny} outputs")
    if len(s["amplitude"]) != model.nu:
        raise InputError(f"group &simulate: amplitude has {len(s['amplitude'])} values, the "
                         f"model has {model.nu} inputs")
    if s["seed"] < 0:
        raise InputError("group &simulate: seed must be >= 0")
    if not len(s["input_shape"]) == len(s["t_start"]) == len(s["pulse_width"]) == model.nu:
        raise InputError(f"group &simulate: input_shape, t_start and pulse_width take one value "
                         f"or one per input ({model.nu})")


def run_case(case):
    """Run one case; returns a dict (JSON-ready) and, for fits, the FitResult."""
    if case.error:
        raise InputError(case.error)
    m = case.groups["model"]
    if case.job == "simulate":
        s = case.groups["simulate"]
        t, u = case.time_input()
        data, _ = core.simulate(case.model, t, u, s["noise_std"] or None, s["seed"],
                                output_names=m["output_names"] or None,
                                input_names=m["input_names"] or None)
        out = case._path(s["out"])
        try:
            data.save(out)
        except OSError as exc:
            raise InputError(f"cannot write {out}: {exc.strerror}") from None
        return {"title": case.title, "job": case.job, "status": 0, "message": "",
                "samples": int(data.nt), "out": str(out)}, None
    result = core.fit(case.model, case.record(), **case.options())
    out = {"title": case.title, "job": case.job, "status": result.status,
           "message": result.message}
    out.update(result.as_dict())
    return out, result


def run_deck(path):
    """Run every case of a deck in order.  Returns a list of (case, output
    dict or None, FitResult or None, error message or None); a failing case
    does not stop the others."""
    runs = []
    for case in read_deck(path):
        try:
            out, result = run_case(case)
            runs.append((case, out, result, None))
        except MlidError as exc:
            runs.append((case, None, getattr(exc, "result", None), str(exc)))
    return runs
