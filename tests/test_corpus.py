"""A corpus of broken and edge-case inputs, run through both front ends.

Every entry is a deck [simulate case, MIDDLE case, good fit] with the middle
case from tests/corpus/cases/ (and, for data records, its record from
tests/corpus/records/).  For an entry that must fail, each front end prints
one clear line naming deck, case 2, line and the problem, never a crash;
the neighbours still run; and `mlid run` and `mlid-batch` fail it with the
same text, print the same report and write the same JSON.  For an entry that
must be READ FINE (OK), all three cases run and both front ends give the
same estimates as the plain deck or record it was derived from.

Whole-deck entries (empty deck, text before the first &case, a directory)
cannot have neighbours: the deck is refused with one line from each front end.

An in-process fuzz test (hypothesis) mutates a good deck and a good record,
and puts Unicode text and invalid UTF-8 into a deck's titles, names, comments
and strings: mlid.read_deck and mlid.FlightData.load may raise only
mlid.MlidError.
"""

import json
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest
try:   # the Makefile installs it; an older .venv may lack it: then only the fuzz tests skip
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st
except ImportError:
    st = None

import mlid
from conftest import BIN

CORPUS = Path(__file__).resolve().parent / "corpus"
OK = None     # expectation: read fine, the middle case runs

SIM = """&case title = 'make data', job = 'simulate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.2, 0.5, -1.0, -2.0,   g = 1.5, 0.3,   h = 1, 0, 0, 1 /
&simulate out = 'small.dat', t_end = 4.0, dt = 0.02, seed = 4, noise_std = 0.01, 0.01,
    input_shape = '3211', amplitude = 1.0, t_start = 0.2, pulse_width = 0.2 /
"""
GOOD = """&case title = 'good fit', job = 'estimate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.0, 0.5, -0.8, -2.0,   g = 1.0, 0.3,   h = 1, 0, 0, 1,
    free = 'f(1,1)', 'f(2,1)', 'g(1,1)', names = 'a11', 'a21', 'b1' /
&data file = 'small.dat', time_col = 1, input_cols = 2, output_cols = 3, 4 /
"""


# ---- transforms of whole decks and of the good record ----------------------

def _bom(b):
    return b"\xef\xbb\xbf" + b


def _tab_before_groups(b):
    """A TAB before each group's '&' (issue 41: '\t&case' was no case start,
    and the deck's batch was lost)."""
    return b"\n".join(b"\t" + line if line.startswith(b"&") else line for line in b.split(b"\n"))


def _crlf(b):
    return b.replace(b"\n", b"\r\n")


def _text_before(b):
    return b"this deck starts with a sentence\n" + b


def _d_exponent(b):
    return b.replace(b"e", b"D")


def _latin1_comments(b):
    lines = b.split(b"\n")
    lines.insert(100, b"# r\xe9glage \xe9t\xe9, 12\xb0C")
    return b"# t u y (\xb5rad, \xb0)\n" + b"\n".join(lines)


def _batch_header(b):
    return b"# t, inputs, outputs (mlid simulate)\n" + b


def _long_comment(b):
    return b"#" + b"x" * 100_000 + b"\n" + b


def _nul_in_row_4(b):
    lines = b.split(b"\n")
    lines[3] = b"\x00" + lines[3][1:]
    return b"\n".join(lines)


def _cr_in_row_4(b):
    lines = b.split(b"\n")
    lines[3] = lines[3][:16] + b"\r" + lines[3][16:]
    return b"\n".join(lines)


def _nul_in_header(b):
    return b"# t u\x00 y1 y2\n" + b


def _esc_in_an_earlier_comment(b):
    return b"# logger \x1b[0m run 7\n# t u y1 y2\n" + b


def _bell_in_a_later_comment(b):
    lines = b.split(b"\n")
    lines.insert(100, b"# \x07 operator's note")
    return b"\n".join(lines)


def _form_feed_in_a_deck_comment(b):
    return b.replace(b"\n", b" ! page\x0c\n", 1)


# ---- the table ---------------------------------------------------------------
# name: (middle case file, expectation, extra)
#   expectation: OK (read fine: all three cases run, same estimates as `same_as`)
#                or a regular expression the problem text must match
#   extra: deck=transform of the whole deck, record=file in records/ (or
#          (file, transform)), same_as=entry whose estimates an OK entry reproduces
ENTRIES = {
    # deck syntax
    "plain deck": ("plain.nml", OK, {}),
    "unknown group": ("unknown_group.nml", r"unknown group &modle", {}),
    "unknown name": ("unknown_name.nml", r"\bfo\b", {}),
    "second &model group": ("second_model.nml", r"&model given twice", {}),
    "missing /": ("missing_slash.nml", r"group &model at line \d+ is not closed with /", {}),
    "unterminated string": ("unterminated_string.nml", r"(unterminated|unclosed|[Ii]nvalid) string|quote", {}),
    "string for nx": ("string_for_nx.nml", r"\bnx\b", {}),
    "real for max_iter": ("real_for_max_iter.nml", r"max_iter", {}),
    "1.0D+00 numbers": ("d_exponent.nml", OK, {"same_as": "plain deck"}),
    "repeat count in a deck": ("repeat_count.nml", OK, {"same_as": "plain deck"}),
    "UTF-8 BOM at the start": ("plain.nml", OK, {"deck": _bom, "same_as": "plain deck"}),
    "CR-LF line ends": ("plain.nml", OK, {"deck": _crlf, "same_as": "plain deck"}),
    "TAB before each group": ("plain.nml", OK, {"deck": _tab_before_groups,
                                                "same_as": "plain deck"}),
    "latin-1 bytes in a comment": ("latin1_comment.nml", OK, {"same_as": "plain deck"}),
    "UTF-8 bytes in a comment": ("utf8_comment.nml", OK, {"same_as": "plain deck"}),
    "TAB characters": ("tabs.nml", OK, {"same_as": "plain deck"}),
    "5000-character line": ("long_line.nml", OK, {"same_as": "plain deck"}),
    "! inside a string": ("bang_in_string.nml", OK, {"same_as": "plain deck",
                                                      "title": "middle ! not a comment"}),
    # model
    "nx = 0": ("nx_0.nml", r"out of range", {}),
    "nx = 31": ("nx_31.nml", r"out of range", {}),
    "nx = -1": ("nx_minus_1.nml", r"out of range", {}),
    "nx = 2147483648": ("nx_2147483648.nml", r"^group &model \(line 8\): line 8: nx has a value "
                                             r"beyond the integers \(-2147483648 to 2147483647\)$",
                        {}),
    "free parameter that does not exist": ("free_missing.nml", r"'f\(3,1\)' does not exist", {}),
    "free parameter listed twice": ("free_twice.nml", r"'f\(1,1\)' listed twice", {}),
    "tie to a missing parameter": ("tie_missing.nml", r"tie 'f\(1,2\)=f\(3,3\)'", {}),
    "matrix with too few values": ("matrix_too_few.nml", r"f has 3 values", {}),
    "matrix with too many values": ("matrix_too_many.nml", r"f has 5 values", {}),
    "NaN in a matrix": ("matrix_nan.nml", r"\bf\b.*not finite", {}),
    "Inf in a matrix": ("matrix_inf.nml", r"\bg\b.*not finite", {}),
    "unknown model kind": ("unknown_kind.nml", r"unknown kind 'lineal'", {}),
    "unknown input_hold": ("unknown_input_hold.nml", r"input_hold must be", {}),
    # estimate
    "max_iter = 2147483647": ("max_iter_huge.nml", r"max_iter.*(at most|<=|limit|must lie in)", {}),
    "max_iter = -1": ("max_iter_negative.nml", r"max_iter", {}),
    "halvings huge": ("halvings_huge.nml", r"halvings.*(at most|<=|limit|must lie in)", {}),
    "rcond = 2": ("rcond_2.nml", r"rcond", {}),
    "unknown method": ("unknown_method.nml", r"method must be", {}),
    "prior with more values than free": ("prior_too_many.nml", r"one value per free parameter", {}),
    "lower with more values than free": ("lower_too_many.nml", r"one value per free parameter", {}),
    "upper with more values than free": ("upper_too_many.nml", r"one value per free parameter", {}),
    "substeps = 0": ("substeps_0.nml", r"substeps", {}),
    "substeps = 100000000": ("substeps_huge.nml", r"substeps.*(at most|<=|limit|must lie in)", {}),
    # simulate
    "t_start = 1e12": ("t_start_1e12.nml", r"t_start", {}),
    "1e12 samples": ("samples_1e12.nml", r"samples; at most", {}),
    "dt = 0": ("dt_0.nml", r"dt > 0", {}),
    "dt = nan": ("dt_nan.nml", r"dt > 0", {}),
    "pulse_width = 0": ("pulse_width_0.nml", r"pulse_width", {}),
    "unknown input_shape": ("unknown_input_shape.nml", r"sine", {}),
    "negative seed": ("negative_seed.nml", r"seed must be >= 0", {}),
    "out into a missing folder": ("out_missing_folder.nml", r"no_such_folder", {}),
    "noise_std with the wrong count": ("noise_std_count.nml", r"noise_std has 3 values", {}),
    # data records
    "good record": ("record.nml", OK, {"record": "good.dat"}),
    "missing record": ("record_missing.nml", r"not found.*no_such_record\.dat", {}),
    "record is a directory": ("record_directory.nml", r"recdir.*directory|directory.*recdir", {}),
    "empty record": ("record.nml", r"no data rows", {"record": "empty.dat"}),
    "record of comments only": ("record.nml", r"no data rows", {"record": "only_comments.dat"}),
    "repeat count 3*0.0 in a row": ("record.nml", r"line 3\b.*(repeat|3\*0\.0)",
                                    {"record": "repeat_count.dat"}),
    "row with a missing column": ("record.nml", r"line 4\b.*column", {"record": "missing_column.dat"}),
    "row with an extra column": ("record.nml", r"line 4\b.*column", {"record": "extra_column.dat"}),
    "NaN in a row": ("record.nml", r"(line|sample|row) 4\b.*(NaN|not finite|infinite)",
                     {"record": "nan.dat"}),
    "Inf in a row": ("record.nml", r"(line|sample|row) 4\b.*(NaN|not finite|infinite)",
                     {"record": "inf.dat"}),
    "time not increasing": ("record.nml", r"(does not|not) increas.*(sample|row|line) 4\b",
                            {"record": "time_not_increasing.dat"}),
    "time gap (two manoeuvres joined)": ("record.nml", r"(gap|uniform).*(t = 5|row 7|line 7|sample 7)",
                                         {"record": "time_gap.dat"}),
    "1.0D+00 in rows": ("record.nml", OK, {"record": ("good.dat", _d_exponent),
                                           "same_as": "good record"}),
    "CR-LF rows": ("record.nml", OK, {"record": ("good.dat", _crlf), "same_as": "good record"}),
    "UTF-8 BOM in a record": ("record.nml", OK, {"record": ("good.dat", _bom),
                                                 "same_as": "good record"}),
    "latin-1 bytes in # comments": ("record.nml", OK, {"record": ("good.dat", _latin1_comments),
                                                       "same_as": "good record"}),
    "# header with commas (as mlid-batch writes it)": (
        "record.nml", OK, {"record": ("good.dat", _batch_header), "same_as": "good record"}),
    "100,000-character comment line": ("record.nml", OK, {"record": ("good.dat", _long_comment),
                                                          "same_as": "good record"}),
    # a NUL cut the message short in mlid run (a C string through f2py), mlid-batch printed it
    "NUL byte in a row": ("record.nml", r"rec\.dat line 4: control character \\x00 at "
                                        r"character 1$", {"record": ("good.dat", _nul_in_row_4)}),
    "CR inside a row": ("record.nml", r"rec\.dat line 4: control character \\x0D at "
                                      r"character 17$", {"record": ("good.dat", _cr_in_row_4)}),
    "NUL byte in the header": ("record.nml", r"rec\.dat line 1: control character \\x00 at "
                                             r"character 6$", {"record": ("good.dat", _nul_in_header)}),
    # a comment holds any bytes, but the header that names the columns, and a deck's text
    # outside its comments, may not
    "ESC in an earlier # comment": ("record.nml", OK, {"record": ("good.dat",
                                                                  _esc_in_an_earlier_comment),
                                                       "same_as": "good record"}),
    "BEL in a # comment among the rows": ("record.nml", OK, {"record": (
        "good.dat", _bell_in_a_later_comment), "same_as": "good record"}),
    "form feed in a deck's ! comment": ("record.nml", OK, {"record": "good.dat",
                                                           "deck": _form_feed_in_a_deck_comment,
                                                           "same_as": "good record"}),
    "columns beyond the file": ("record_cols_beyond.nml", r"column 7 requested",
                                {"record": "good.dat"}),
    # issue 41, class 7 (decks)
    # a form feed outside quoted text is a blank (a page break); inside it, and any other
    # control character outside a comment, fails its case alone (it failed the whole deck)
    "form feeds between values and groups": ("form_feed.nml", OK, {"same_as": "plain deck"}),
    "form feed in a quoted name": ("form_feed_in_a_name.nml",
                                   r"^line 14: control character \\x0C at character 59$", {}),
    "NUL byte in a quoted name": ("nul_in_a_name.nml",
                                  r"^line 14: control character \\x00 at character 59$", {}),
    # the largest number was the sentinel of 'not given': now it is read as given
    "the largest number as a value": ("huge_value_given.nml",
                                      r"delay\(1\) = 0\.1798E\+309 s is not shorter", {}),
    "&simulate in an estimate case": ("simulate_in_estimate.nml",
                                      r"^line 16: group &simulate is not read by job 'estimate' "
                                      r"\(it reads &case, &model, &data, &estimate\)$", {}),
    "&data in a simulate case": ("data_in_simulate.nml",
                                 r"^line 12: group &data is not read by job 'simulate' \(it reads "
                                 r"&case, &model, &simulate\)$", {}),
    "prior with 2 of 3 values": ("prior_partial.nml", r"prior has 2 values; .*one value per "
                                                      r"free parameter \(3", {}),
    "lower with 1 of 3 values": ("lower_partial.nml", r"lower has 1 values; .*one value per "
                                                      r"free parameter \(3", {}),
    "an element given twice through a strided section": (
        "strided_twice.nml", r"^line 12: h\(4\) given twice in group &model \(first at line "
                             r"12\)$", {}),
    "21 data files": ("files_21.nml", r"^group &data: file has 21 entries; a case takes at "
                                      r"most 20 manoeuvres \(data files\)$", {}),
    "tol_grad = inf": ("tol_grad_inf.nml", r"^tolerances tol_cost, tol_step, tol_grad must be "
                                           r"finite and >= 0$", {}),
    # null values keep their element's default (the namelist way): bias, x0 zero
    "null values and r* nulls": ("null_values.nml", OK, {"same_as": "plain deck"}),
    "a title of 100 characters in 200 bytes": ("utf8_title.nml", OK, {"same_as": "plain deck",
                                                                      "title": "\u00e9" * 100}),
    # a job's blanks around it are no part of it: ' estimate ' is estimate
    "job with blanks around it": ("job_blanks.nml", OK, {"same_as": "plain deck"}),    # issue 41 follow-ups (a held-out corpus): elements of lists with a default (x0, bias, d,
    # delay, r) named alone keep the others' default, as a null does
    "elements of lists with a default named alone": ("elements_by_index.nml", OK,
                                                     {"same_as": "plain deck"}),
    # sections with a stride are legal: a stride of 0, and more values than the elements
    # of a section, are named as such (not "one index", not "given twice")
    "a stride of 0": ("stride_0.nml", r"^line 14: x0\(1:2:0\): the stride is 0 \(NAME\(i:j:s\) "
                                      r"takes every s-th element from i to j\)$", {}),
    "3 values for a section of 2 elements": (
        "section_too_many.nml", r"^line 13: h\(1:4:2\) has 3 values for its 2 elements in group "
                                r"&model$", {}),
    # gfortran's "Integer overflow while reading item 1", "Bad repeat count in item 1":
    # the item named
    "max_iter = -2147483649": ("max_iter_overflow.nml",
                               r"^group &estimate \(line 15\): line 15: max_iter has a value beyond "
                               r"the integers \(-2147483648 to 2147483647\)$", {}),
    "a number for a logical": ("steady_state_number.nml",
                               r"^group &estimate \(line 15\): line 15: steady_state takes T or F "
                               r"\(true or false\), not a number$", {}),
    # the limit, as for 21 data files (the namelist read blamed a value)
    "201 free parameters": ("free_201.nml", r"^group &model: free has 201 entries; a case takes "
                                            r"at most 200 free parameters$", {}),
    # free has no default: a null would drop a parameter unseen (it fitted 2)
    "a null in free": ("free_null.nml", r"^group &model: free\(2\) is a null value, and free has "
                                        r"no default to keep$", {}),
    # a name takes non-ASCII bytes: the message quotes it whole
    "a group name with a non-ASCII letter": ("group_non_ascii.nml",
                                             r"^line 8: unknown group &modèle \(groups are ", {}),
    "a name with a non-ASCII letter": ("name_non_ascii.nml", r"^group &model \(line 8\): line 8: "
                                                            r"unknown name ñx in group &model$", {}),
    # the report's label column is 16 bytes: the message says bytes, and quotes the label whole
    "a label of 6 CJK characters (18 bytes)": (
        "label_cjk.nml", r"^group &model: the label '日本語日本語' of free parameter 1 is longer "
                         r"than the 16 bytes the report prints", {}),
    "a label of 16 × é (32 bytes)": (
        "label_16_e_acute.nml", r"^group &model: the label 'é{16}' of free parameter 1 is longer "
                                r"than the 16 bytes the report prints", {}),
    # its square, the variance r, overflowed: "parameter 21 is not finite"
    "noise_std = 1e200": ("noise_std_huge.nml", r"^group &simulate: noise_std\(1\) is too large: "
                                                r"its square, the variance r, is beyond the largest "
                                                r"number", {}),
    # tables (definitions 'T(u) = breakpoints', params 'T[i] = start')
    "a table's breakpoints that do not increase": (
        "table_breakpoints_decrease.nml", r"^group &model: equations model: table T, breakpoints "
                                          r"of u: the breakpoints must increase$", {}),
    "a start for no table value": (
        "table_start_of_no_value.nml", r"^group &model: params entry 'T\[4\] = 1' is not "
                                       r"'NAME\[i\] = value' of a table's value$", {}),
    # a params entry 'NAME = value' whose NAME is no name: said, not a blank name read on
    "a params entry whose name is no name": (
        "params_not_a_name.nml", r"^group &model: params entry 'CD al = 0': 'CD al' in "
                                 r"'CD al = 0' is not a name$", {}),
    # the same table value's start given twice: the last won unseen
    "a table value's start given twice": (
        "table_start_twice.nml", r"^group &model: params entry 'T\[2\] = 3' gives T\[2\] a "
                                 r"start value a second time$", {}),
    # issue 45: the online job's recursive least squares ('rls'): its settings and its model
    "rls with p0 for 3 of 2 outputs": ("rls_p0_count.nml", r"^group &online: 'rls' takes one p0 "
                                       r"\(P0 = p0 I\) for all outputs or one per output \(2\), "
                                       r"got 3$", {}),
    "rls on a model with states": ("rls_states.nml", r"^group &online: 'rls' regresses the outputs "
                                   r"of a model with no states \(nx = 0, e\.g\. kind = "
                                   r"'equations'\), not nx = 2$", {}),
    "rls on an output not linear in its parameter": (
        "rls_nonlinear.nml", r"^online: 'rls' regresses outputs linear in the free parameters; "
                             r"output y2 is not \(sample \d+\)$", {}),
    # issue 45: the deck's model-structure job ('stepwise', &stepwise; no &model)
    "stepwise with an unknown method": ("stepwise_method.nml", r"^group &stepwise: method must "
                                        r"be 'forward', 'backward' or 'mof', not 'sideways'$", {}),
    "stepwise forcing a term that is no candidate": (
        "stepwise_forced.nml", r"^group &stepwise: forced term 'u\^3' is not among the 3 "
                               r"candidates$", {}),
    "stepwise knots on a variable not in &data": (
        "stepwise_knot_var.nml", r"^group &stepwise: knot_vars 'alpha' is not one of &data's "
                                 r"input_cols \(the variables\)$", {}),
    "stepwise with no output_cols": ("stepwise_no_outputs.nml", r"^group &data: a stepwise case "
                                     r"needs output_cols \(the measured coefficients whose "
                                     r"model structure it finds\)$", {}),
    "stepwise candidate named beyond 64 bytes (two 32-byte channels at degree 2)": (
        "stepwise_long_name.nml", r"^group &stepwise: candidate 'a{32}\*b{32}' is longer than "
                                  r"a candidate's name may be \(64 bytes\)$", {}),
    "&model in a stepwise case": ("stepwise_model.nml", r"^line \d+: group &model is not read by "
                                  r"job 'stepwise' \(it reads &case, &data, &stepwise\)$", {}),
}

# whole decks that are refused as a whole: name -> (how to make the deck, phrase)
WHOLE = {
    "empty deck": ("empty.nml", r"no &case group"),
    "text before the first &case": ("plain.nml", r"line 1\b.*text before the first &case"),
    "deck that is a directory": (None, r"directory"),
}
WHOLE_TRANSFORM = {"text before the first &case": _text_before}

FORBIDDEN = ("Traceback", "Error termination", "internal error", "Fortran runtime error",
             "Segmentation fault", "SIGSEGV", "Backtrace", "core dumped", "Program received signal")
TIMEOUT = 60


def _run(cmd, cwd):
    try:
        p = subprocess.run(cmd, capture_output=True, cwd=cwd, timeout=TIMEOUT)
        return p.returncode, p.stdout.decode(errors="replace"), p.stderr.decode(errors="replace")
    except subprocess.TimeoutExpired:
        return None, "", f"TIMEOUT after {TIMEOUT} s"


class Outcome:
    """Both front ends run on one deck: (returncode, stdout, stderr, json text)."""

    def __init__(self, folder, deck):
        self.folder, self.deck = folder, deck
        self.runs = {}
        for who in ("mlid", "mlid-batch"):
            jf = folder / f"{who}.json"
            cmd = [str(BIN / who)] + (["run"] if who == "mlid" else []) + [str(deck), "--json",
                                                                          str(jf)]
            rc, out, err = _run(cmd, folder)
            self.runs[who] = (rc, out, err, jf.read_text(errors="replace") if jf.exists() else None)

    def error_lines(self, who):
        return [ln for ln in self.runs[who][2].splitlines() if ln.startswith(who + ": ")]

    def problem(self, who):
        """(line, title, problem) of the single case-2 error line, else None."""
        lines = self.error_lines(who)
        pat = re.compile(rf"{re.escape(who)}: {re.escape(str(self.deck))} case 2 "
                         r"\(line (\d+)\) '(.*?)': (.*)$")
        if len(lines) != 1 or not pat.match(lines[0]):
            return None
        return pat.match(lines[0]).groups()


_CACHE = {}


def _middle_bytes(name):
    case_file, _, extra = ENTRIES[name]
    return (CORPUS / "cases" / case_file).read_bytes()


def _outcome(name, tmp_path_factory):
    if name in _CACHE:
        return _CACHE[name]
    case_file, _, extra = ENTRIES[name]
    folder = tmp_path_factory.mktemp("corpus")
    deck_bytes = SIM.encode() + b"\n" + _middle_bytes(name) + b"\n" + GOOD.encode()
    if "deck" in extra:
        deck_bytes = extra["deck"](deck_bytes)
    deck = folder / "batch.nml"
    deck.write_bytes(deck_bytes)
    rec = extra.get("record")
    if rec is not None:
        src, fn = rec if isinstance(rec, tuple) else (rec, None)
        data = (CORPUS / "records" / src).read_bytes()
        (folder / "rec.dat").write_bytes(fn(data) if fn else data)
    (folder / "recdir").mkdir()
    _CACHE[name] = Outcome(folder, deck)
    return _CACHE[name]


def _no_crash(o):
    for who, (rc, out, err, _) in o.runs.items():
        assert rc in (0, 1), (who, rc, err[-2000:])
        for bad in FORBIDDEN:
            assert bad not in err and bad not in out, (who, bad, err[-2000:])


def _stdout(o, who):
    return [ln for ln in o.runs[who][1].splitlines() if not ln.startswith(" plot:")]


FAILING = sorted(n for n, e in ENTRIES.items() if e[1] is not OK)
READ_FINE = sorted(n for n, e in ENTRIES.items() if e[1] is OK)


def test_the_corpus_is_small_and_large_enough():
    files = [p for p in CORPUS.rglob("*") if p.is_file()]
    assert sum(p.stat().st_size for p in files) < 200_000
    assert len(ENTRIES) + len(WHOLE) >= 60
    used = {e[0] for e in ENTRIES.values()} | {w[0] for w in WHOLE.values() if w[0]}
    assert {p.name for p in (CORPUS / "cases").iterdir()} == used


# ---- failing entries -----------------------------------------------------------

@pytest.mark.parametrize("name", FAILING)
def test_one_clear_line_naming_the_problem(name, tmp_path_factory):
    o = _outcome(name, tmp_path_factory)
    _no_crash(o)
    phrase = ENTRIES[name][1]
    for who in ("mlid", "mlid-batch"):
        rc, out, err, _ = o.runs[who]
        assert rc == 1, (who, err)
        got = o.problem(who)
        assert got is not None, (who, "want one line 'case 2 (line L) ...'", err)
        assert got[1] == "middle", (who, got)
        assert re.search(phrase, got[2]), (who, phrase, got[2])


@pytest.mark.parametrize("name", FAILING)
def test_neighbours_still_run(name, tmp_path_factory):
    o = _outcome(name, tmp_path_factory)
    _no_crash(o)
    for who in ("mlid", "mlid-batch"):
        rc, out, err, _ = o.runs[who]
        assert "simulated 201 samples" in out, (who, out, err)
        assert out.count("converged (") == 1, (who, out)
        assert "1 of 3 cases failed" in err, (who, err)


@pytest.mark.parametrize("name", FAILING)
def test_both_front_ends_fail_alike(name, tmp_path_factory):
    o = _outcome(name, tmp_path_factory)
    _no_crash(o)
    a, b = o.problem("mlid"), o.problem("mlid-batch")
    assert a is not None and b is not None, (o.runs["mlid"][2], o.runs["mlid-batch"][2])
    assert a == b, (a, b)
    assert _stdout(o, "mlid") == _stdout(o, "mlid-batch")


@pytest.mark.parametrize("name", FAILING)
def test_json_names_the_failure(name, tmp_path_factory):
    """Whatever its layout, each JSON file says case 2 failed, with the
    problem printed on stderr."""
    o = _outcome(name, tmp_path_factory)
    _no_crash(o)
    for who in ("mlid", "mlid-batch"):
        text = o.runs[who][3]
        assert text is not None, (who, "no JSON written", o.runs[who][2])
        cases = json.loads(text)
        assert [c["status"] != 0 for c in cases] == [False, True, False], (who, cases)
        got = o.problem(who)
        assert got is not None and cases[1]["message"] == got[2], (who, cases[1], got)


@pytest.mark.parametrize("name", FAILING + READ_FINE)
def test_json_identical(name, tmp_path_factory):
    o = _outcome(name, tmp_path_factory)
    _no_crash(o)
    ja, jb = o.runs["mlid"][3], o.runs["mlid-batch"][3]
    assert ja is not None and jb is not None
    a, b = json.loads(ja), json.loads(jb)
    assert len(a) == len(b) == 3
    assert ja == jb


# ---- entries that must be read fine ---------------------------------------------

def _estimates(o, who, k):
    ja = o.runs[who][3]
    assert ja is not None, (who, o.runs[who][2])
    return np.array(json.loads(ja)[k]["estimate"])


@pytest.mark.parametrize("name", READ_FINE)
def test_read_fine(name, tmp_path_factory):
    o = _outcome(name, tmp_path_factory)
    _no_crash(o)
    extra = ENTRIES[name][2]
    for who in ("mlid", "mlid-batch"):
        rc, out, err, _ = o.runs[who]
        assert rc == 0 and not o.error_lines(who), (who, err)
        assert "simulated 201 samples" in out
        assert out.count("converged (") == 2, (who, out)
        assert f" case 2: {extra.get('title', 'middle')}\n" in out, (who, out)
        assert json.loads(o.runs[who][3])[1]["parameters"] == ["a11", "a21", "b1"]
    assert _stdout(o, "mlid") == _stdout(o, "mlid-batch")
    np.testing.assert_allclose(_estimates(o, "mlid", 1), _estimates(o, "mlid-batch", 1),
                               rtol=1e-10, atol=0)
    if "same_as" in extra:
        ref = _outcome(extra["same_as"], tmp_path_factory)
        for who in ("mlid", "mlid-batch"):
            np.testing.assert_allclose(_estimates(o, who, 1), _estimates(ref, who, 1),
                                       rtol=1e-9, atol=0)


# ---- whole decks refused ----------------------------------------------------------

@pytest.mark.parametrize("name", sorted(WHOLE))
def test_whole_deck_refused_with_one_line(name, tmp_path):
    src, phrase = WHOLE[name]
    if src is None:
        deck = tmp_path / "deckdir.nml"
        deck.mkdir()
    else:
        deck = tmp_path / "batch.nml"
        body = (CORPUS / "cases" / src).read_bytes()
        if src != "empty.nml":
            body = SIM.encode() + b"\n" + body + b"\n" + GOOD.encode()
        deck.write_bytes(WHOLE_TRANSFORM.get(name, lambda b: b)(body))
    o = Outcome(tmp_path, deck)
    _no_crash(o)
    texts = []
    for who in ("mlid", "mlid-batch"):
        rc, out, err, _ = o.runs[who]
        assert rc == 1, (who, err)
        lines = o.error_lines(who)
        assert len(lines) == 1, (who, err)
        assert re.search(phrase, lines[0]), (who, phrase, lines[0])
        assert "simulated" not in out
        texts.append(lines[0][len(who) + 2:])
    assert texts[0] == texts[1]


# ---- fuzz: mutated decks and records, in-process ------------------------------------

GOOD_DECK = (SIM + "\n" + (CORPUS / "cases" / "plain.nml").read_text() + "\n" + GOOD).encode()
GOOD_RECORD = b"".join((CORPUS / "records" / "good.dat").read_bytes().splitlines(True)[:30])

if st is None:
    def test_fuzz_needs_hypothesis():
        pytest.skip("hypothesis is not installed (make install adds it to a new .venv)")
else:
    _byte = st.one_of(st.integers(32, 126), st.integers(0, 31), st.integers(127, 255))
    _token = st.sampled_from([b"&", b"/", b"'", b'"', b",", b"=", b"!", b"#", b"*", b"3*", b"nan",
                              b"-Infinity", b"1e999", b"2147483648", b"1.0D+00", b"\r", b"\t",
                              b"\xef\xbb\xbf", b"\n&case ", b"\n&model ", b" nx = 0", b"(0,0)"])
    _mutation = st.one_of(
        st.tuples(st.just("insert"), st.floats(0, 1), _token.map(list)),
        st.tuples(st.just("insert"), st.floats(0, 1), st.lists(_byte, min_size=1, max_size=8)),
        st.tuples(st.just("delete"), st.floats(0, 1), st.integers(1, 40)),
        st.tuples(st.just("duplicate line"), st.floats(0, 1), st.integers(1, 3)),
        st.tuples(st.just("replace"), st.floats(0, 1), st.lists(_byte, min_size=1, max_size=4)),
    )


    def _mutate(data, mutations):
        b = bytearray(data)
        for op, where, arg in mutations:
            k = int(where * len(b)) if b else 0
            if op == "insert":
                b[k:k] = bytes(arg)
            elif op == "delete":
                del b[k:k + arg]
            elif op == "replace":
                b[k:k + len(arg)] = bytes(arg)
            else:
                lines = bytes(b).split(b"\n")
                j = min(int(where * len(lines)), len(lines) - 1)
                lines[j:j] = [lines[j]] * arg
                b = bytearray(b"\n".join(lines))
        return bytes(b)


    FUZZ = settings(max_examples=200, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))


    @FUZZ
    @given(st.lists(_mutation, min_size=1, max_size=6))
    def test_fuzz_read_deck(mutations):
        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / "deck.nml"
            path.write_bytes(_mutate(GOOD_DECK, mutations))
            try:
                cases = mlid.read_deck(path)
            except mlid.MlidError:
                return
            for case in cases:
                assert case.error is None or isinstance(case.error, str)


    # decks with Unicode (issue 41): random non-ASCII text put into titles, names, comments
    # and quoted strings, or anywhere, as UTF-8, or as raw bytes (invalid UTF-8 among them)
    _SLOTS = [b"title = 'middle", b"names = 'a11", b"'f(1,1)", b"output_cols = 3, 4 /",
              b"job = 'estimate'", b"&model", b"nx = 2,"]
    _unicode = st.one_of(
        st.text(st.characters(min_codepoint=0x80, max_codepoint=0x10FFFF,
                              blacklist_categories=("Cs",)), min_size=1, max_size=12)
        .map(lambda t: t.encode()),
        st.binary(min_size=1, max_size=8),
        st.sampled_from([b"\xc3", b"\xe2\x80", b"\xff\xfe", b"\xed\xa0\x80", b"\xc0\xaf",
                         "é".encode() * 200, "\u2212".encode(), "\u00a0".encode(),
                         "\u201cq\u201d".encode()]))
    _placement = st.one_of(
        st.tuples(st.sampled_from(["slot", "comment"]), st.integers(0, len(_SLOTS) - 1),
                  _unicode),
        st.tuples(st.just("anywhere"), st.floats(0, 1), _unicode))


    def _place(data, placements):
        b = data
        for how, where, text in placements:
            if how == "slot":
                slot = _SLOTS[where]
                b = b.replace(slot, slot + text, 1)
            elif how == "comment":
                slot = _SLOTS[where]
                b = b.replace(slot, slot + b" ! " + text + b"\n", 1)
            else:
                k = int(where * len(b))
                b = b[:k] + text + b[k:]
        return b


    @settings(max_examples=150, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck))
    @given(st.lists(_placement, min_size=1, max_size=4))
    def test_fuzz_read_deck_unicode(placements):
        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / "deck.nml"
            path.write_bytes(_place(GOOD_DECK, placements))
            try:
                cases = mlid.read_deck(path)
            except mlid.MlidError:
                return
            for case in cases:
                assert case.error is None or isinstance(case.error, str)
                assert isinstance(case.title, str)


    @FUZZ
    @given(st.lists(_mutation, min_size=1, max_size=6))
    def test_fuzz_load_record(mutations):
        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / "rec.dat"
            path.write_bytes(_mutate(GOOD_RECORD, mutations))
            try:
                data = mlid.FlightData.load(path, time_col=1, input_cols=[2], output_cols=[3, 4])
            except mlid.MlidError:
                return
            assert data.u.shape == (data.nt, 1) and data.y.shape == (data.nt, 2)
