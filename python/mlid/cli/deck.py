"""Batch decks, read by the core's reader (fortran/case/mlid_deck.f90), the one
mlid-batch uses: Python only turns each case spec into objects.  See
docs/guide/decks.md for every group and name."""

import json
from pathlib import Path

import numpy as np

from .._bridge import (Handle, api as _api, counted, counter_id, lines as _lines,
                       text as _text, values)
from ..data.flight_data import FlightData, read_status
from ..errors import MlidError, check_status, guarded, status_of
from ..estimate.fit import fit_result
from ..estimate.options import options_of_text
from ..model.models import free_entries, from_core
from ..report.validation import validation_of


#: The most terms one tie has (the core's limit).
TIE_TERMS = int(_api.mlid_limit("tie_terms"))

#: The numeric flight-condition items of &case, in the core's order.
CONDITIONS = tuple(n.strip() for n in _text(_api.mlid_condition_names()).split(","))

#: The jobs whose cases have a &model (the core's deck groups: 'group|jobs|names' a line);
#: a case of another job ('stepwise') makes no model object.
MODEL_JOBS = frozenset(next(line.split("|")[1].split()
                            for line in _text(_api.mlid_deck_groups()).splitlines()
                            if line.startswith("model|")))


class Case:
    """Case k of a deck: what to run, or why it cannot run (``error``).  The
    deck's cases stay in the core, in the handle its cases share."""

    def __init__(self, deck, handle, k):
        self._handle = handle
        v = values(handle, k, "case")
        self.index, self.deck, self.line = k, Path(deck), v["line"]
        self.title, self.job = _text(v["title"]), _text(v["job"])
        self._title = v["title"]          # the deck's own bytes, for the core's JSON
        self.error = _text(v["message"]) if v["status"] else None
        self._condition = {n: x for n, x, g in zip(CONDITIONS, v["condition"].tolist(),
                                                   v["condition_given"]) if g}
        if _text(v["config"]):
            self._condition["config"] = _text(v["config"])
        if _text(v["tags"]):
            self._condition["tags"] = [t.strip() for t in _text(v["tags"]).split(",")
                                       if t.strip()]
        self.model = None
        self.warnings = []                # the records' (record()), as mlid-batch says them
        if self.error or self.job not in MODEL_JOBS:
            return
        opts = options_of_text(v["options"])
        theta, isfree = v["theta"], v["isfree"]
        ties = (v["tie_to"], v["tie_from"], v["tie_scale"], v["tie_offset"])
        nx, nu, ny, nw = v["sizes"].tolist()
        self.model = from_core(v["mkind"], (nx, nu, ny, nw), v["iconst"], v["rconst"], theta,
                               isfree, ties, _lines(v["labels"]), opts.pop("input_hold"),
                               opts.pop("substeps"))
        order = free_entries(isfree)
        free = [self.model.element_names()[j] for j in order]
        if v["use_prior"]:
            opts.update(prior=dict(zip(free, v["prior"][order])),
                        prior_weight=v["pweight"])
        if v["use_bounds"]:
            big = np.finfo(float).max
            # a NaN bound goes on to the core, which refuses it as mlid-batch does
            opts["bounds"] = {f: (None if lo <= -big else lo, None if hi >= big else hi)
                              for f, lo, hi in zip(free, v["lower"][order], v["upper"][order])
                              if not (lo <= -big and hi >= big)}
        self._options = opts
        self._sizes = (nu, ny)
        self._names = (_lines(v.get("input_names", b"")) or None,
                       _lines(v.get("output_names", b"")) or None)
        self._files = _lines(v.get("data_files", b""))
        self.holdout = [int(j) for j in v.get("holdout", ())]   # validate: the files predicted
        # kind flight_path: where each manoeuvre's corrected record goes (&estimate corrected)
        self.corrected = _lines(v.get("corrected", b""))
        x0 = v.get("initial_states", np.zeros(0))
        if x0.size and len(self._files) > 1:            # each manoeuvre's own x0
            self._options["initial_states"] = list(x0.reshape(-1, nx))
        elif x0.size:
            self.model.x0 = x0
        if "x0_from" in v:                              # &estimate x0_from, x0_samples
            self._options.update(x0_from=_text(v["x0_from"]), x0_samples=int(v["x0_samples"]))

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
        return self._names

    def record(self, files=None):
        """The FlightData of an estimate case, read from its data files as the
        core reads them for mlid-batch (channels, units, derived channels,
        windows, units shown; text, .mat and HDF5 files).  A list when the
        case names several files (several manoeuvres) or ``files`` is given:
        the numbers (from 1) of the files to read, in that order.  Warnings
        of the reader (a channel declared in rad beyond 2 pi) are
        MlidWarnings, and are added to ``warnings``."""
        inputs, outputs = self.channel_names()
        # a case without files asks for file 1: the core says it has none
        numbers = range(1, max(len(self._files), 1) + 1) if files is None else files
        records = []
        for j in numbers:
            out = Handle()
            nt, status, msg = _api.mlid_deck_case_record(self._handle.value, self.index, j,
                                                         out.value)
            note = read_status(status, msg)
            if note:
                self.warnings.append(note)
            records.append(FlightData._taken(out, *self._sizes, nt, self._files[j - 1], inputs,
                                             outputs))
        return records[0] if len(records) == 1 and files is None else records

    def options(self):
        """Options for fit(): the &estimate group by name, with prior,
        prior_weight and bounds where the deck gives them."""
        return dict(self._options)


class CaseOutput(dict):
    """What the core's job runner gave for a case (fortran/case/mlid_run.f90,
    the one mlid-batch runs): its JSON object as a dict (and a fit's
    ``wall_time_s``, which no JSON file holds: two runs' bytes are the
    same), ``report`` (the
    lines both front ends print), ``json_text`` (the bytes both write),
    ``notes`` (warnings and the failure, one line each, for stderr),
    ``status`` and ``message``."""

    def __init__(self, report, json_text, notes, status, message):
        super().__init__(json.loads(json_text))
        self.report, self.json_text, self.notes = report, json_text, notes
        self.status, self.message = status, message


#: The jobs whose case is a fit (its FitResult made from the run's numbers).
FIT_JOBS = ("estimate", "validate")


def case_json(case, out=None, error=None):
    """The JSON object of a case as the core wrote it (mlid-batch writes the
    same bytes); for a case that did not run, title, job, status and message."""
    if isinstance(out, CaseOutput):
        return out.json_text
    text, n = _api.mlid_case_json(case._title, case.job, status_of(error) if error else 0,
                                  str(error or ""), -1, "")
    return text[:n].decode("utf-8", "surrogateescape")


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
def run_case(case, progress=None):
    """Run one case in the core's job runner, as mlid-batch runs it: its
    report, JSON and files are the core's (a CaseOutput), and a fit's
    FitResult is made from the numbers the run kept, read by name (none for
    the other jobs).  A case that failed raises its MlidError, carrying the
    FitResult of a failed fit (``result``) and the output (``output``).
    ``progress`` (as mlid.progress.bar takes it: None, when stderr is a
    terminal): a bar for the case's long work, counted by the core in a
    handle of its own."""
    case.warnings = []
    counter, bar = counted(progress)
    with bar:
        status, msg = _api.mlid_deck_case_run(case._handle.value, case.index,
                                              counter_id(counter))
    kept = values(case._handle, case.index, "run")
    if "report" not in kept:            # refused before it ran
        check_status(status, msg)
    out = CaseOutput(*(kept[k].decode("utf-8", "surrogateescape") for k in ("report", "json")),
                     kept["notes"].decode("utf-8", "surrogateescape").splitlines(), int(status),
                     _text(msg))
    if "wall_time" in kept:             # the fit's own time, as FitResult.as_dict() has it
        out["wall_time_s"] = kept["wall_time"]
    result = _fit_of(case, kept) if case.job in FIT_JOBS else None
    if out.status != 0:
        try:
            check_status(out.status, out.message)
        except MlidError as exc:
            exc.result, exc.output = result, out
            raise
    return out, result


def _fit_of(case, kept):
    """The FitResult of the fit case's run kept (None when it fitted
    nothing), with its Validation for a validate case."""
    if "theta" not in kept:
        return None
    out = dict(kept, message=_text(kept["message"]))
    numbers = range(1, len(case._files) + 1)
    data = case.record([j for j in numbers if j not in case.holdout])
    try:
        result = fit_result(case.model, data if len(data) > 1 else data[0], out,
                            **case.options())
    except MlidError as exc:           # a failed fit: the error carries it
        if getattr(exc, "result", None) is None:
            raise
        return exc.result
    if "theil" in kept:
        result.validation = _validation_of(case, result, kept)
    return result


def _validation_of(case, result, kept):
    """The Validation the run computed: the core's statistics and
    prediction, the held-out records read as the run read them."""
    # read in file order, as the run joined them; numbered as the deck lists them
    return validation_of(result, case.record(sorted(case.holdout)), case.holdout, kept["theil"],
                         kept["rms"], kept["rms_over_sigma"], kept["prediction"].T.copy())


def iter_deck(path):
    """Run every case of a deck in order, yielding (case, output dict or None,
    FitResult or None, the MlidError or None) as each ends; a failing case
    does not stop the others."""
    return run_cases(read_deck(path))


def run_cases(cases, progress=None):
    """As ``iter_deck`` for cases ``read_deck`` has read already (progress:
    as ``run_case`` takes it)."""
    for case in cases:
        try:
            out, result = run_case(case, progress)
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
