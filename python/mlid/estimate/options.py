"""The core's estimator options by name: its option table, the flat arrays a
core call takes (set and checked by the core), and the defaults."""

import numpy as np

from .._bridge import api as _api, text as _text
from ..errors import InputError, check_status, guarded


#: Options that are the model's (Model.input_hold, Model.substeps), not fit()'s.
_MODEL_OPTIONS = ("input_hold", "substeps")


def _option_kinds():
    """The core's option table: {name: kind}, kind 'int', 'real', 'bool' or
    'choice'.  Names, positions and choices live in fortran/estimation/mlid_options.f90."""
    kinds, k = {}, 1
    while True:
        name, kind = (_text(v) for v in _api.mlid_option_info(k))
        if not name:
            return kinds
        kinds[name] = kind
        k += 1


_KINDS = _option_kinds()


_TYPES = {"int": int, "real": float, "bool": lambda s: s == "true", "choice": str}


def options_by_name(iopt, ropt):
    """Every option of the core's flat arrays, by name (the model's too)."""
    return {name: _TYPES[kind](_text(_api.mlid_option_get(iopt, ropt, name)))
            for name, kind in _KINDS.items()}


def options_of_text(text):
    """The options by name from the core's text of them (mlid_options's
    options_text: 'name value' a line), as options_by_name gives them."""
    pairs = (line.split(" ", 1) for line in text.decode().splitlines())
    return {name: _TYPES[_KINDS[name]](value) for name, value in pairs}


def _as_dict(iopt, ropt):
    opts = options_by_name(iopt, ropt)
    return {name: v for name, v in opts.items() if name not in _MODEL_OPTIONS}


def _as_text(value):
    if type(value) is str:          # a choice: as it is
        return value
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    return str(value)


@guarded
def default_options():
    """The core's default estimator options, by name.

    Returns
    -------
    dict
        {name: value} of every option ``fit`` takes (fortran/estimation/mlid_options.f90).
    """
    return _as_dict(*_api.mlid_default_options())


#: _flat_options' answers by the options given: the core's options are a
#: function of them, and asking it costs about 40 f2py
#: calls a fit (each option set, then every one read back).  Errors are
#: raised before anything is kept; cleared when full.
_OPTIONS_MADE = {}


_OPTIONS_KEPT = 256


def _flat_options(model, options):
    """The core's flat option arrays for fit() options and the model's own,
    set by name (the core checks names and values), and the options by name
    (copies: the caller may keep or change them)."""
    given = dict(options)
    unknown = [n for n in given if n not in _KINDS or n in _MODEL_OPTIONS]
    if unknown:
        raise InputError(f"unknown option {unknown[0]!r}; known: {', '.join(default_options())}")
    given.update(input_hold=model.input_hold, substeps=model.substeps)
    # the plain values' own types in the key (True and 1 are the same key
    # otherwise), their texts only for what is not hashable
    try:
        pairs = tuple((name, value.__class__, value) for name, value in given.items())
        made = _OPTIONS_MADE.get(pairs)
    except TypeError:
        pairs = tuple((name, _as_text(value)) for name, value in given.items())
        made = _OPTIONS_MADE.get(pairs)
    if made is None:
        texts = tuple((name, _as_text(value)) for name, value in given.items())
        iopt, ropt = _api.mlid_default_options()
        for name, text in texts:
            status, msg = _api.mlid_option_set(iopt, ropt, name, text)
            check_status(status, msg)
        check_status(*_api.mlid_options_check(iopt, ropt))
        made = iopt, ropt, _as_dict(iopt, ropt)
        if len(_OPTIONS_MADE) >= _OPTIONS_KEPT:
            _OPTIONS_MADE.clear()
        _OPTIONS_MADE[pairs] = made
    iopt, ropt, opts = made
    return iopt.copy(), ropt.copy(), dict(opts)


#: fit()'s options that evaluate() does not take (they shape the iteration)
FIT_ONLY = ("prior", "prior_weight", "bounds")


def evaluate_options(options):
    """A fit's options as evaluate() takes them (FIT_ONLY left out)."""
    return {k: v for k, v in options.items() if k not in FIT_ONLY}
