"""Batch decks, read by the core's reader (fortran/case/mlid_deck.f90), the one
mlid-batch uses: Python only turns each case spec into objects.  See
README.md for every group and name."""

import json
from pathlib import Path

import numpy as np

from .._bridge import VALUE_INT, VALUE_TEXT, Handle, api as _api, lines as _lines, text as _text
from ..data.flight_data import FlightData, read_status
from ..errors import InputError, MlidError, check_status, guarded, status_of
from ..estimate.fit import FIT_OUTPUTS, fit_result
from ..estimate.options import options_by_name
from ..model.models import from_core
from ..report.validation import validation_of


#: The most terms one tie has (the core's limit).
TIE_TERMS = int(_api.mlid_limit("tie_terms"))

#: The numeric flight-condition items of &case, in the core's order.
CONDITIONS = tuple(n.strip() for n in _text(_api.mlid_condition_names()).split(","))


class Case:
    """Case k of a deck: what to run, or why it cannot run (``error``).  The
    deck's cases stay in the core, in the handle its cases share."""

    def __init__(self, deck, handle, k):
        self._handle = handle
        h = handle.value
        (self.line, title, job, status, msg, mkind, nx, nu, ny, nw, nth, nf, nic, nrc, nfile,
         nt) = _api.mlid_deck_case(h, k)
        self.index, self.deck, self.title, self.job = k, Path(deck), _text(title), _text(job)
        self._title = title.rstrip()      # the deck's own bytes, for the core's JSON
        self.error = _text(msg) if status else None
        values, given, config, tags = _api.mlid_deck_case_condition(h, k, len(CONDITIONS))
        self._condition = {n: float(v) for n, v, g in zip(CONDITIONS, values, given) if g}
        if _text(config):
            self._condition["config"] = _text(config)
        if _text(tags):
            self._condition["tags"] = [t.strip() for t in _text(tags).split(",") if t.strip()]
        self.model = None
        self.warnings = []                # the records' (record()), as mlid-batch says them
        if self.error:
            return
        (theta, isfree, iconst, rconst, iopt, ropt, labels, use_prior, prior, pweight,
         use_bounds, lower, upper) = _api.mlid_deck_case_model(h, k, nth, nf, nic, nrc)
        opts = options_by_name(iopt, ropt)
        n, to, frm, scale, offset = _api.mlid_deck_case_ties(h, k, nth, TIE_TERMS * nth)
        ties = (to[:n], frm[:n], scale[:n], offset)
        self.model = from_core(mkind, (nx, nu, ny, nw), iconst, rconst, theta, isfree, ties,
                               _lines(labels), opts.pop("input_hold"), opts.pop("substeps"))
        free = [self.model.element_names()[j] for j in np.flatnonzero(isfree)]
        if use_prior:
            opts.update(prior=dict(zip(free, prior[isfree == 1])), prior_weight=pweight)
        if use_bounds:
            big = np.finfo(float).max
            # a NaN bound goes on to the core, which refuses it as mlid-batch does
            opts["bounds"] = {f: (None if lo <= -big else lo, None if hi >= big else hi)
                              for f, lo, hi in zip(free, lower[isfree == 1], upper[isfree == 1])
                              if not (lo <= -big and hi >= big)}
        self._options = opts
        self._sizes = (nu, ny)
        self._files = [_api.mlid_deck_case_data(h, k, j) for j in range(1, max(nfile, 1) + 1)]
        n, holdout = _api.mlid_deck_case_holdout(h, k, max(nfile, 1))
        self.holdout = [int(j) for j in holdout[:n]]   # validate: the files predicted
        # kind flight_path: where each manoeuvre's corrected record goes (&estimate corrected)
        self.corrected = [p for p in (_text(_api.mlid_deck_case_corrected(h, k, j))
                                      for j in range(1, nfile + 1)) if p]
        n, x0 = _api.mlid_deck_case_initial_states(h, k, max(nx, 1) * max(nfile, 1))
        if n and nfile > 1:                            # each manoeuvre's own x0
            self._options["initial_states"] = list(x0[:n].reshape(-1, nx))
        elif n:
            self.model.x0 = x0[:n]

    def where(self):
        return f"{self.deck} case {self.index} (line {self.line}) '{self.title}'"

    @property
    def condition(self):
        """The flight condition the deck gives in &case: {name: value} of
        the numeric items given (CONDITIONS), 'config' and 'tags' (a list)
        when given."""
        return dict(self._condition)


    def channel_names(self):
        """The deck's input and output names (None where not given)."""
        return tuple(_lines(n) or None for n in self._files[0][-2:])

    def record(self, files=None):
        """The FlightData of an estimate case, read from its data files as the
        core reads them for mlid-batch (channels, units, derived channels,
        windows, units shown); .mat and HDF5 files are read by this front
        end into a table the core then takes the same way.  A list when the
        case names several files (several manoeuvres) or ``files`` is given:
        the numbers (from 1) of the files to read, in that order.  Warnings
        of the reader (a channel declared in rad beyond 2 pi) are
        MlidWarnings, and are added to ``warnings``."""
        inputs, outputs = self.channel_names()
        numbers = range(1, len(self._files) + 1) if files is None else files
        records = []
        for j in numbers:
            path = _text(self._files[j - 1][0])
            nt, status, msg = _api.mlid_deck_case_record(self._handle.value, self.index, j)
            note = read_status(status, msg)
            if note:
                self.warnings.append(note)
            records.append(FlightData._taken(self._handle, *self._sizes, nt, path, inputs,
                                             outputs))
        return records[0] if len(records) == 1 and files is None else records

    def options(self):
        """Options for fit(): the &estimate group by name, with prior,
        prior_weight and bounds where the deck gives them."""
        return dict(self._options)


class CaseOutput(dict):
    """What the core's job runner gave for a case (fortran/case/mlid_run.f90,
    the one mlid-batch runs): its JSON object as a dict, ``report`` (the
    lines both front ends print), ``json_text`` (the bytes both write),
    ``notes`` (warnings and the failure, one line each, for stderr),
    ``status`` and ``message``."""

    def __init__(self, report, json_text, notes, status, message):
        super().__init__(json.loads(json_text))
        self.report, self.json_text, self.notes = report, json_text, notes
        self.status, self.message = status, message


#: The jobs whose case is a fit (its FitResult made from the run's numbers).
FIT_JOBS = ("estimate", "validate")


def case_json(case, out=None, result=None, error=None):
    """The JSON object of a case as the core wrote it (mlid-batch writes the
    same bytes); for a case that did not run, title, job, status and message."""
    if isinstance(out, CaseOutput):
        return out.json_text
    text, n = _api.mlid_case_json(case._title, case.job, status_of(error) if error else 0,
                                  str(error or ""), -1, "")
    return text[:n].decode(errors="replace")


def json_list(objects):
    """The --json file: the cases' objects as one list (as mlid-batch writes it)."""
    return "[\n" + ",\n".join(objects) + ("\n" if objects else "") + "]\n"


@guarded
def read_deck(path):
    """All cases of a deck, read by the core's reader (the one mlid-batch uses).

    Parameters
    ----------
    path : str or Path
        The namelist deck.

    Returns
    -------
    list of Case
        One per ``&case``, in order; a case that cannot run carries its
        ``error`` (one line naming the group and problem) instead of a model.

    Raises
    ------
    InputError
        If the deck cannot be read at all (missing, empty, unreadable).
    """
    path = Path(path)
    handle = Handle()
    ncases, status, msg = _api.mlid_deck_open(handle.value, str(path))
    check_status(status, msg)
    return [Case(path, handle, k) for k in range(1, ncases + 1)]


@guarded
def run_case(case):
    """Run one case in the core's job runner, as mlid-batch runs it: its
    report, JSON and files are the core's (a CaseOutput), and a fit's
    FitResult is made from the numbers the run kept, read by name (none for
    the other jobs).  A case that failed raises its MlidError, carrying the
    FitResult of a failed fit (``result``) and the output (``output``)."""
    case.warnings = []
    (report, nreport, text, njson, notes, nnotes, status,
     msg) = _api.mlid_deck_case_run(case._handle.value, case.index)
    out = CaseOutput(report[:nreport].decode(errors="replace"),
                     text[:njson].decode(errors="replace"),
                     notes[:nnotes].decode(errors="replace").splitlines(), int(status),
                     _text(msg))
    result = _fit_of(case) if case.job in FIT_JOBS else None
    if out.status != 0:
        try:
            check_status(out.status, out.message)
        except MlidError as exc:
            exc.result, exc.output = result, out
            raise
    return out, result


def _fit_of(case):
    """The FitResult of the fit case's run kept (None when it fitted
    nothing), with its Validation for a validate case."""
    h, k = case._handle.value, case.index
    out = {}
    for name in FIT_OUTPUTS + ("wall_time",):
        kind, rank, shape = _api.mlid_case_result_info(h, k, name)
        if kind == 0:
            return None
        out[name] = _result_value(h, k, name, kind, rank, shape)
    numbers = range(1, len(case._files) + 1)
    files = [j for j in numbers if j not in case.holdout]
    data = case.record(files)
    try:
        result = fit_result(case.model, data if len(data) > 1 else data[0], out,
                            **case.options())
    except MlidError as exc:           # a failed fit: the error carries it
        return exc.result
    if case.job == "validate" and _api.mlid_case_result_info(h, k, "theil")[0]:
        result.validation = _validation_of(case, result)
    return result


def _result_value(h, k, name, kind, rank, shape):
    if kind == VALUE_TEXT:
        return _text(_api.mlid_case_result_text(h, k, name))
    dims = tuple(int(n) for n in shape[:rank])
    values, status, msg = _api.mlid_case_result(h, k, name, int(np.prod(dims)))
    check_status(status, msg)
    if not dims:
        return int(values[0]) if kind == VALUE_INT else float(values[0])
    values = values.reshape(dims, order="F")
    return values.astype(int) if kind == VALUE_INT else values


def _validation_of(case, result):
    """The Validation the run computed: the core's statistics and
    prediction, the held-out records read as the run read them."""
    h, k = case._handle.value, case.index
    kept = sorted(case.holdout)
    held = case.record(kept)
    value = {}
    for name in ("theil", "rms", "rms_over_sigma", "prediction"):
        kind, rank, shape = _api.mlid_case_result_info(h, k, name)
        value[name] = _result_value(h, k, name, kind, rank, shape)
    return validation_of(result, held, kept, value["theil"], value["rms"],
                         value["rms_over_sigma"], value["prediction"].T.copy())


def iter_deck(path):
    """Run every case of a deck in order, yielding (case, output dict or None,
    FitResult or None, the MlidError or None) as each ends; a failing case
    does not stop the others."""
    return run_cases(read_deck(path))


def run_cases(cases):
    """As ``iter_deck`` for cases ``read_deck`` has read already."""
    for case in cases:
        try:
            out, result = run_case(case)
            yield case, out, result, None
        except MlidError as exc:
            yield case, getattr(exc, "output", None), getattr(exc, "result", None), exc


def run_deck(path):
    """Every case of a deck run in order.

    Parameters
    ----------
    path : str or Path
        The namelist deck.

    Returns
    -------
    list of tuple
        What ``iter_deck`` yields for each case: (case, output dict or None,
        FitResult or None, MlidError or None); a failing case does not stop
        the others.

    Raises
    ------
    InputError
        If the deck cannot be read at all.
    """
    return list(iter_deck(path))
