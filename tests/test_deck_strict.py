"""Bad decks the namelist reader must not read silently wrong: a name given
twice, a word for a logical, text outside the groups, a group not closed,
lists shorter than their items, values out of range, a record written over
its own input, values longer than their room.  Each is refused by both
front ends in one line naming the case, the line and the problem, and the
cases before and after it still run."""

import pytest

from conftest import refused_by_both, run_both
from test_corpus import SIM      # the first case: the record the others fit
# the middle case (its &case line is line 6 of the deck)
FIT = """&case title = 'middle', job = 'estimate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.0, 0.5, -0.8, -2.0,   g = 1.0, 0.3,   h = 1, 0, 0, 1,
    free = 'f(1,1)', 'f(2,1)', 'g(1,1)', names = 'a11', 'a21', 'b1' /
&data file = 'small.dat', time_col = 1, input_cols = 2, output_cols = 3, 4 /
&estimate max_iter = 20, halvings = 5 /
"""
GOOD = FIT.replace("'middle'", "'good fit'")


def _refused(tmp_path, middle, message):
    """[simulate, middle, good fit]: both front ends refuse the middle case
    with message, and run its neighbours."""
    deck = tmp_path / "deck.nml"
    deck.write_text(SIM + middle + GOOD)
    refused_by_both(deck, message, cwd=tmp_path)
    for run in run_both(deck, cwd=tmp_path):
        errors = [ln for ln in run.stderr.splitlines() if "case 2 (line 6) 'middle'" in ln]
        assert len(errors) == 1 and message in errors[0], run.stderr
        assert "simulated 201 samples" in run.stdout and run.stdout.count("converged (") == 1
        assert "1 of 3 cases failed" in run.stderr


# middle case text -> the message (lines of the deck: the middle case's
# &model is line 7, its &estimate line 11)
SCANNED = {
    "a scalar twice": (FIT.replace("halvings = 5", "halvings = 5, max_iter = 3"),
                       "line 11: max_iter given twice in group &estimate (first at line 11)"),
    "nx twice": (FIT.replace("nx = 2,", "nx = 2, nx = 3,"),
                 "line 7: nx given twice in group &model (first at line 7)"),
    "a list twice, the second shorter": (
        FIT.replace("'b1' /", "'b1',\n    names = 'A' /"),
        "line 10: names given twice in group &model (first at line 9)"),
    "an element set twice by index": (
        FIT.replace("'b1' /", "'b1', x0 = 1.0, 2.0, x0(2) = 5.0 /"),
        "line 9: x0(2) given twice in group &model (first at line 9)"),
    "a logical by its first letter": (FIT.replace("halvings = 5", "steady_state = tomato"),
                                      "line 11: bad value tomato for steady_state in group "
                                      "&estimate: not a number, not quoted text and not a "
                                      "logical"),
    "a word for a logical": (FIT.replace("halvings = 5", "partials = fish"),
                             "line 11: bad value fish for partials"),
    "text after a group's /": (FIT.replace("halvings = 5 /", "halvings = 5 / max_iter = 3"),
                               "line 11: 'max_iter = 3' is outside any group (a group is "
                               "&name ... /, a comment starts with !)"),
    "a stray line": (FIT.replace("&estimate", "max_iter = 3\n&estimate"),
                     "line 11: 'max_iter = 3' is outside any group"),
    "a group commented with #": (FIT + "# &estimate max_iter = 3 /\n",
                                 "line 12: '# &estimate max_iter = 3 /' is outside any group"),
    "a $group $end": (FIT.replace("&estimate max_iter = 20, halvings = 5 /",
                                  "$estimate max_iter = 3 $end"),
                      "line 11: '$estimate': a group starts with &name and ends with / "
                      "($name ... $end and &end are not read)"),
    "a group ended by &end": (FIT.replace("halvings = 5 /", "halvings = 5 &end"),
                              "line 11: '&end': a group starts with &name and ends with /"),
    "the last group not closed": (FIT.replace("halvings = 5 /", "halvings = 5"),
                                  "group &estimate at line 11 is not closed with /"),
    "a group before another not closed": (
        FIT.replace("output_cols = 3, 4 /", "output_cols = 3, 4"),
        "group &data at line 10 is not closed with /"),
}


@pytest.mark.parametrize("name", sorted(SCANNED))
def test_the_deck_text_is_read_whole_or_refused(tmp_path, name):
    middle, message = SCANNED[name]
    _refused(tmp_path, middle, message)


def test_elements_by_index_and_sections_are_read(tmp_path):
    """x(i) = ... and x(i:j) = ... on elements not given before are read (the
    bounds of cases/hfb320), and the same as the whole list given once."""
    deck = tmp_path / "deck.nml"
    runs = {}
    for name, est in (("list", "lower = -9, -8, -7, upper = 1e3, 1e3, 1e3"),
                      ("index", "lower(1) = -9, lower(2:3) = -8, -7, upper = 3*1e3")):
        deck.write_text(SIM + FIT.replace("halvings = 5", "halvings = 5, " + est))
        both = run_both(deck, cwd=tmp_path)
        assert all(r.returncode == 0 for r in both), both[0].stderr
        runs[name] = [r.stdout for r in both]
    assert runs["list"] == runs["index"] and runs["list"][0] == runs["list"][1]


# legal namelist syntax the scan once refused: each must read as the plain deck
LEGAL = {
    "logicals with periods": ("halvings = 5", "halvings = 5, steady_state = .f., partials = .T"),
    "a name with its = on the next line": ("halvings = 5", "halvings\n    = 5"),
    "a repeat count of quoted text": ("names = 'a11', 'a21', 'b1'",
                                      "names = 1*'a11', 'a21', names(3) = 'b1'"),
    "a null value before an element set by index": ("h = 1, 0, 0, 1,",
                                                    "h = , 0, 0, 1, h(1) = 1,"),
    # each group's namelist read sees that group's text alone (issue 41)
    "a group's name in quoted text": ("job = 'estimate'",
                                      "job = 'estimate', config = 'a &estimate b'"),
}


@pytest.mark.parametrize("name", sorted(LEGAL))
def test_legal_namelist_syntax_reads_as_the_plain_deck(tmp_path, name):
    plain, legal = LEGAL[name]
    assert plain in FIT
    deck = tmp_path / "deck.nml"
    outs = []
    for middle in (FIT, FIT.replace(plain, legal)):
        deck.write_text(SIM + middle + GOOD)
        both = run_both(deck, cwd=tmp_path)
        assert all(r.returncode == 0 for r in both), both[0].stderr
        assert both[0].stdout == both[1].stdout
        outs.append(both[0].stdout)
    assert outs[0] == outs[1]


def test_a_group_after_a_quoted_bang_on_its_line_is_read(tmp_path):
    """Each group's namelist read is given that group's text alone (issue
    41), so a ! in quoted text before a group on its line hides nothing: the
    &estimate after 'y!1' is read (it was refused, and before that never
    read: the fit ran with the default options)."""
    deck = tmp_path / "deck.nml"
    outs = []
    for sep in ("\n", " "):               # &estimate on a line of its own, then after 'y!1'
        middle = FIT.replace("\n&estimate max_iter = 20, halvings = 5 /", "").replace(
            "'b1' /", "'b1', output_names = 'y!1', 'y2' /" + sep + "&estimate max_iter = 1 /")
        assert ("'y!1', 'y2' / &estimate" in middle) == (sep == " ")
        deck.write_text(SIM + middle + GOOD)
        both = run_both(deck, cwd=tmp_path)
        assert all(r.returncode == 0 for r in both), both[0].stderr
        assert both[0].stdout == both[1].stdout
        assert "not converged after 1 iteration" in both[0].stderr, both[0].stderr
        outs.append(both[0].stdout)
    assert outs[0] == outs[1]


# lists of one value per item given too short (none given keeps the default),
# and values out of range that were taken as something else
READ = {
    "names too few": (FIT.replace("names = 'a11', 'a21', 'b1'", "names = 'a11', 'a21'"),
                      "group &model: names has 2 labels for 3 free parameters (one per free "
                      "parameter, in the order of free, or none)"),
    "state_names too few": (FIT.replace("h = 1, 0, 0, 1,", "h = 1, 0, 0, 1, state_names = 'u',"),
                            "group &model: state_names names every state (nx = 2) or none; "
                            "given 1"),
    "t_start for one of two files": (
        FIT.replace("file = 'small.dat',", "file = 'small.dat', 'small.dat', t_start = 0.5,"),
        "group &data: t_start and t_end take one value per file (in the order of file) or "
        "none; given 1 and 0 for 2 files"),
    "&data dt = 0": (FIT.replace("output_cols = 3, 4 /", "output_cols = 3, 4, dt = 0 /"),
                     "group &data: dt must be > 0 (a uniform time step replacing the record's "
                     "time), or left out"),
    "&simulate noise_std < 0": (
        SIM.replace("'make data'", "'middle'").replace("noise_std = 0.01, 0.01",
                                                       "noise_std = 0.01, -0.01")
        .replace("small.dat", "other.dat"),
        "group &simulate: noise_std (the standard deviation of each output's noise) must be "
        ">= 0 and finite"),
}


@pytest.mark.parametrize("name", sorted(READ))
def test_short_lists_and_values_out_of_range_are_refused(tmp_path, name):
    middle, message = READ[name]
    _refused(tmp_path, middle, message)


def _simulate(out, input_file):
    """A simulate case named 'middle' writing out from input_file."""
    return (SIM.replace("'make data'", "'middle'")
            .replace("out = 'small.dat', t_end = 4.0, dt = 0.02,", f"out = '{out}',")
            .replace("input_shape = '3211', amplitude = 1.0, t_start = 0.2, pulse_width = 0.2",
                     f"input_file = '{input_file}'"))


def test_a_record_is_not_written_over_its_own_input_or_the_deck(tmp_path):
    """out naming its input_file (the same file by another name too) or the
    deck is refused before anything is written; both files stay as they were."""
    (tmp_path / "sub").mkdir()
    for out, input_file in (("small.dat", "small.dat"), ("sub/../small.dat", "./small.dat"),
                            ("deck.nml", "small.dat")):
        (tmp_path / "small.dat").unlink(missing_ok=True)
        _refused(tmp_path, _simulate(out, input_file),
                 f"group &simulate: out '{tmp_path / out}' is the deck or the input_file: the "
                 "record written would overwrite what it is made from")
        assert (tmp_path / "deck.nml").read_text().startswith(SIM)


LONG = {
    "a label wider than the report's column": (
        FIT.replace("names = 'a11'", "names = 'a_rather_long_label'"),
        "group &model: the label 'a_rather_long_label' of free parameter 1 is longer than the 16 "
        "bytes the report prints (a shorter one in names)"),
    "an output name over 32 characters": (
        FIT.replace("h = 1, 0, 0, 1,", "h = 1, 0, 0, 1, output_names = 'y1', '" + "y" * 33 + "',"),
        "line 8: a value of output_names in group &model is longer than its 32 bytes"),
    "a state name over 32 characters, its quotes doubled": (
        FIT.replace("h = 1, 0, 0, 1,", "h = 1, 0, 0, 1, state_names = 'x1', '" + "x''" * 16
                    + "x',"),
        "line 8: a value of state_names in group &model is longer than its 32 bytes"),
    "a file name over 511 characters": (
        FIT.replace("file = 'small.dat'", "file = '" + "d/" * 300 + "small.dat'"),
        "...' is longer than 511 bytes (with the deck's folder)"),
}


@pytest.mark.parametrize("name", sorted(LONG))
def test_values_longer_than_their_room_are_refused(tmp_path, name):
    """A label wider than the report's column (16), a file name over 511
    characters: refused, never cut."""
    middle, message = LONG[name]
    _refused(tmp_path, middle, message)


@pytest.mark.parametrize("entry", ["config = '{}'".format("c" * 65),
                                   "tags = '{}'".format("t" * 257)])
def test_a_config_or_tags_longer_than_their_room_is_refused(tmp_path, entry):
    """They were cut without a word (a campaign table's column)."""
    _refused(tmp_path, FIT.replace("job = 'estimate' /", f"job = 'estimate', {entry} /"),
             "group &case: config is longer than 64 bytes, or tags than 256")


def test_a_title_longer_than_128_characters_is_refused(tmp_path):
    deck = tmp_path / "deck.nml"
    title = "t" * 129
    deck.write_text(SIM + FIT.replace("'middle'", f"'{title}'") + GOOD)
    for run in run_both(deck, cwd=tmp_path):
        assert run.returncode == 1
        assert f"'{title[:128]}': group &case: title is longer than 128 characters" in run.stderr
        assert "1 of 3 cases failed" in run.stderr and run.stdout.count("converged (") == 1


BLAMED = {
    "an unknown name after a text value": (
        FIT.replace("halvings = 5", "noise = 'diagonal', tol_cst = 1e-6"),
        "group &estimate (line 11): line 11: unknown name tol_cst in group &estimate"),
    "an index beyond the array": (FIT.replace("'b1' /", "'b1', x0(99) = 1.0 /"),
                                  "group &model (line 7): line 9: x0(99): the index lies outside "
                                  "x0"),
    "two indices": (FIT.replace("'b1' /", "'b1', f(1,1) = 2.0 /"),
                    "group &model (line 7): line 9: f(1,1): a deck's lists take one index, "
                    "NAME(i), NAME(i:j) or NAME(i:j:s) (a matrix is one list, row by row)"),
    "more values than a name takes": (
        FIT.replace("'b1' /", "'b1', x0 = " + "1, " * 40 + "bias = 0, 0 /"),
        "group &model (line 7): a value stands where a name should be (read as '1'): a "
        "name given more values than it takes, or a name without ="),
}


@pytest.mark.parametrize("name", sorted(BLAMED))
def test_a_namelist_error_names_what_is_wrong(tmp_path, name):
    middle, message = BLAMED[name]
    _refused(tmp_path, middle, message)


def test_a_design_is_not_written_over_the_deck(tmp_path):
    design = """&case title = 'middle', job = 'design' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.0, 0.5, -0.8, -2.0,   g = 1.0, 0.3,   h = 1, 0, 0, 1, r = 0.01, 0.01,
    free = 'f(1,1)', 'g(1,1)' /
&design t_end = 2.0, dt = 0.02, energy = 1.0, out = './deck.nml' /
"""
    _refused(tmp_path, design, f"group &design: out '{tmp_path}/./deck.nml' is the deck or the "
                               "input_file: the record written would overwrite what it is made from")
    assert (tmp_path / "deck.nml").read_text().startswith(SIM)


# ---- issue 41, class 7 ---------------------------------------------------------------

def test_a_title_is_limited_in_characters_not_bytes(tmp_path):
    """128 characters of UTF-8 (here 256 bytes) are a title; 129 are refused,
    the message naming characters (the limit was 128 bytes)."""
    deck = tmp_path / "deck.nml"
    deck.write_text(SIM + FIT.replace("'middle'", "'" + "é" * 128 + "'") + GOOD)
    for run in run_both(deck, cwd=tmp_path):
        assert run.returncode == 0, run.stderr
        assert f" case 2: {'é' * 128}\n" in run.stdout
    _refused_title = "é" * 129
    deck.write_text(SIM + FIT.replace("'middle'", f"'{_refused_title}'") + GOOD)
    for run in run_both(deck, cwd=tmp_path):
        assert run.returncode == 1
        assert (f"'{'é' * 128}': group &case: title is longer than 128 characters"
                in run.stderr), run.stderr


OTHER_JOBS = {
    "&estimate in a design case": (
        """&case title = 'middle', job = 'design' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.0, 0.5, -0.8, -2.0,   g = 1.0, 0.3,   h = 1, 0, 0, 1, r = 0.01, 0.01,
    free = 'f(1,1)', 'g(1,1)' /
&design t_end = 2.0, dt = 0.02, energy = 1.0, out = 'designed.dat' /
&estimate max_iter = 3 /
""", "line 11: group &estimate is not read by job 'design' (it reads &case, &model, &design)"),
    "&monte_carlo in an estimate case": (
        FIT + "&monte_carlo runs = 3 /\n",
        "line 12: group &monte_carlo is not read by job 'estimate' (it reads &case, &model, "
        "&data, &estimate)"),
}


@pytest.mark.parametrize("name", sorted(OTHER_JOBS))
def test_a_group_of_another_job_is_refused(tmp_path, name):
    middle, message = OTHER_JOBS[name]
    _refused(tmp_path, middle, message)


NULLS = {
    "a null in a block that has no default": (
        FIT.replace("f = -1.0, 0.5,", "f = , 0.5,"),
        "group &model: f(1) is a null value, and f has no default to keep (it is needed)"),
    "the brief's strided section": (
        FIT.replace("'b1' /", "'b1', x0(1:2:1) = 1, 2, x0(2) = 3 /"),
        "line 9: x0(2) given twice in group &model (first at line 9)"),
    "a list given from its second element": (
        FIT.replace("max_iter = 20", "max_iter = 20, prior_weight(2:3) = 1, 1, prior(2) = 1"),
        None),
    "a null in a list without a default": (
        SIM.replace("'make data'", "'middle'").replace("noise_std = 0.01, 0.01",
                                                       "noise_std = , 0.01")
        .replace("small.dat", "other.dat"),
        "group &simulate: noise_std(1) is a null value, and noise_std has no default to keep"),
}


@pytest.mark.parametrize("name", sorted(NULLS))
def test_null_values_and_elements(tmp_path, name):
    """A null value keeps its element's default (the namelist way), so a
    block without one refuses it; elements given by index are read as given."""
    middle, message = NULLS[name]
    if message is not None:
        _refused(tmp_path, middle, message)
        return
    deck = tmp_path / "deck.nml"
    deck.write_text(SIM + middle + GOOD)
    assert all(r.returncode == 0 for r in run_both(deck, cwd=tmp_path))


def test_a_50_mb_single_line_deck_is_refused_in_one_line(tmp_path):
    """A deck of one 50 MB line whose seed is a number of 50 million digits
    overflowed the stack (an automatic copy of the word in the scan): both
    front ends segfaulted.  Now each says what is wrong in one line."""
    deck = tmp_path / "big.nml"
    deck.write_text(SIM.replace("\n", " ").replace("seed = 4,", "seed = 4" + "0" * 50_000_000
                                                     + ",") + "\n")
    for run in run_both(deck, cwd=tmp_path):
        assert run.returncode == 1, run.stderr[-500:]
        errors = [ln for ln in run.stderr.splitlines() if "case 1 (line 1) 'make data'" in ln]
        assert len(errors) == 1 and "group &simulate" in errors[0], run.stderr[-500:]
        assert len(errors[0]) < 400


def test_a_deck_is_read_alike_under_a_file_size_limit(tmp_path):
    """The reader copied each case to a scratch file, which `ulimit -f` cut,
    and the case then read other options (issue 41).  It reads from memory
    now: a case larger than the limit reads the same with and without it."""
    import subprocess
    from conftest import BIN
    deck = tmp_path / "deck.nml"
    deck.write_text(SIM)
    assert all(r.returncode == 0 for r in run_both(deck, cwd=tmp_path))   # small.dat
    # text a namelist read takes (leading blanks), past the limit of 2 KiB
    indented = "".join(" " * 1000 + f"{k} = {v}\n" for k, v in (
        ("halvings", 5), ("tol_cost", "1e-12"), ("tol_step", "1e-12"), ("max_iter", 2)))
    middle = FIT.replace("max_iter = 20, halvings = 5 /", "\n" + indented + "/")
    deck.write_text(middle + GOOD)
    assert middle.index("max_iter = 2") > 4096
    outs = {}
    for limit in ("unlimited", "2"):
        for exe, pre in (("mlid", "run "), ("mlid-batch", "")):
            run = subprocess.run(["bash", "-c", f"ulimit -f {limit}; '{BIN / exe}' {pre}'{deck}'"],
                                 capture_output=True, text=True, cwd=tmp_path)
            assert run.returncode == 0, run.stderr
            outs[limit, exe] = (run.stdout, run.stderr.replace(exe + ": ", ""))
    assert outs["2", "mlid"] == outs["unlimited", "mlid"] == outs["2", "mlid-batch"] \
        == outs["unlimited", "mlid-batch"]
    assert "not converged after 2 iterations" in outs["2", "mlid"][1]   # its options read


# ---- issue 41 follow-ups (a held-out corpus) -----------------------------------------

# an element of a list with a default named alone sets it, the others keep their default
# (as a null does): each pair reads alike, through both front ends
BY_INDEX = {
    "x0": ("'b1' /", "'b1', x0(2) = 0.05 /", "'b1', x0 = 0.0, 0.05 /"),
    "bias and d": ("'b1' /", "'b1', bias(2) = 0.01, d(2) = 0.1 /",
                   "'b1', bias = 0.0, 0.01, d = 0.0, 0.1 /"),
    "delay": ("'b1' /", "'b1', delay(2) = 0.02 /", "'b1', delay = 0.0, 0.02 /"),
    "&data t_start of the second file": (
        "file = 'small.dat',", "file = 'small.dat', 'small.dat', t_start(2) = 0.5,",
        "file = 'small.dat', 'small.dat', t_start = 0.0, 0.5,"),
}


@pytest.mark.parametrize("name", sorted(BY_INDEX))
def test_elements_named_alone_keep_the_others_default(tmp_path, name):
    plain, by_index, whole = BY_INDEX[name]
    deck = tmp_path / "deck.nml"
    outs = []
    for text in (by_index, whole):
        deck.write_text(SIM + FIT.replace(plain, text) + GOOD)
        both = run_both(deck, cwd=tmp_path)
        assert all(r.returncode == 0 for r in both), both[0].stderr
        assert both[0].stdout == both[1].stdout
        outs.append(both[0].stdout)
    assert outs[0] == outs[1]
    deck.write_text(SIM + FIT + GOOD)
    assert run_both(deck, cwd=tmp_path)[0].stdout != outs[0]   # the element did count


FOLLOW_UPS = {
    "an element beyond a list with a default": (
        FIT.replace("'b1' /", "'b1', x0(3) = 1.0 /"),
        "group &model: x0(3) is given, and x0 takes 2 values"),
    "an element beyond a matrix with a default": (
        FIT.replace("'b1' /", "'b1', d(3) = 1.0 /"),
        "group &model: d(3) is given, and d takes 2 values (2x1, row by row)"),
    "a stride that does not go from i to j": (
        FIT.replace("'b1' /", "'b1', x0(1:2:-1) = 1.0 /"),
        "line 9: x0(1:2:-1): a stride of -1 does not go from 1 to 2 (NAME(i:j:s) takes every "
        "s-th element from i to j)"),
    "a section's upper bound below its lower": (
        FIT.replace("'b1' /", "'b1', x0(2:1) = 1.0 /"),
        "line 9: x0(2:1): a stride of 1 does not go from 2 to 1"),
    "3 values for a section of 2": (
        FIT.replace("'b1' /", "'b1', x0(1:2) = 1, 2, 3 /"),
        "line 9: x0(1:2) has 3 values for its 2 elements in group &model"),
    "an integer overflow in the second item": (
        FIT.replace("halvings = 5", "halvings = 99999999999"),
        "group &estimate (line 11): line 11: halvings has a value beyond the integers "
        "(-2147483648 to 2147483647)"),
    "an integer overflow in &data": (
        FIT.replace("output_cols = 3, 4 /", "output_cols = 3, 4, skip_rows = -2147483649 /"),
        "group &data (line 10): line 10: skip_rows has a value beyond the integers"),
    "an integer overflow in &simulate": (
        SIM.replace("'make data'", "'middle'").replace("seed = 4", "seed = 4294967296")
        .replace("small.dat", "other.dat"),
        "group &simulate (line 9): line 9: seed has a value beyond the integers"),
    "a real for a logical": (FIT.replace("halvings = 5", "halvings = 5, partials = 0.5"),
                             "group &estimate (line 11): line 11: partials takes T or F (true or "
                             "false), not a number"),
    "a repeat count for a scalar": (FIT.replace("halvings = 5", "halvings = 2*5"),
                                    "group &estimate (line 11): line 11: halvings is given more "
                                    "values than it takes (r*value is r values)"),
    # a word cut to its room read as another: 'linear' and ten blanks and x was linear
    "a kind longer than its room": (FIT.replace("kind = 'linear'", "kind = 'linear          x'"),
                                    "line 7: a value of kind in group &model is longer than its "
                                    "16 bytes"),
    "a job longer than its room": (FIT.replace("job = 'estimate'", "job = 'estimate        x'"),
                                   "line 6: a value of job in group &case is longer than its 16 "
                                   "bytes"),
    "a null in names": (FIT.replace("names = 'a11', 'a21', 'b1'", "names = 'a11', , 'b1'"),
                        "group &model: names(2) is a null value, and names has no default to keep"),
    "free from its second element": (
        FIT.replace("free = 'f(1,1)', 'f(2,1)', 'g(1,1)', names = 'a11', 'a21', 'b1'",
                    "free(2) = 'f(2,1)'"),
        "group &model: free(1) is left out, free(2) given (a list is given from its first "
        "element on)"),
    "201 a priori values": (FIT.replace("halvings = 5", "halvings = 5, prior = 201*1.0"),
                            "group &estimate: prior has 201 entries; a case takes at most 200 "
                            "free parameters"),
    "a label over the 32 bytes of its room": (
        FIT.replace("names = 'a11'", "names = '" + "日" * 11 + "'"),
        "line 9: a value of names in group &model is longer than its 32 bytes"),
}


@pytest.mark.parametrize("name", sorted(FOLLOW_UPS))
def test_follow_ups_are_refused_in_their_words(tmp_path, name):
    middle, message = FOLLOW_UPS[name]
    _refused(tmp_path, middle, message)


def test_a_message_never_cuts_a_utf8_character(tmp_path):
    """A group name of 30 × 'é' is quoted cut to 37 bytes: at a character's
    end (18 of them), never inside one; stderr and JSON are valid UTF-8."""
    import subprocess
    from conftest import BIN
    deck = tmp_path / "deck.nml"
    deck.write_text(SIM + FIT.replace("&model", "&" + "é" * 30, 1) + GOOD)
    for exe, pre in (("mlid", ["run"]), ("mlid-batch", [])):
        run = subprocess.run([str(BIN / exe), *pre, str(deck), "--json", str(tmp_path / "o.json")],
                             capture_output=True, cwd=tmp_path)
        err = run.stderr.decode("utf-8")          # strict: no byte of a cut character
        assert f"line 7: unknown group &{'é' * 18}... (groups are" in err, err
        js = (tmp_path / "o.json").read_bytes().decode("utf-8")
        assert "\ufffd" not in js and "é" * 18 + "..." in js


# a plain deck of every job, read where the stack is small: &model's lists on the stack
# (over 512 KB) overflowed a thread's stack and `ulimit -s 512`; both front ends segfaulted
EVERY_JOB = SIM + FIT + """&case title = 'design', job = 'design' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.0, 0.5, -0.8, -2.0,   g = 1.0, 0.3,   h = 1, 0, 0, 1, r = 0.01, 0.01,
    free = 'f(1,1)', 'g(1,1)' /
&design t_end = 2.0, dt = 0.02, energy = 1.0, out = 'designed.dat' /
&case title = 'mc', job = 'monte_carlo' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.0, 0.5, -0.8, -2.0,   g = 1.0, 0.3,   h = 1, 0, 0, 1, r = 0.01, 0.01,
    free = 'f(1,1)', 'g(1,1)' /
&monte_carlo runs = 2, input_file = 'small.dat' /
&estimate max_iter = 5 /
"""


def test_a_deck_reads_in_a_thread_of_256_kb(tmp_path):
    """mlid.read_deck in a thread whose stack is 256 KB (in a child process:
    a stack overflow would end the test run)."""
    import subprocess
    import sys
    deck = tmp_path / "deck.nml"
    deck.write_text(EVERY_JOB)
    code = f"""
import threading, mlid
threading.stack_size(256 * 1024)
got = []
t = threading.Thread(target=lambda: got.append(mlid.read_deck({str(deck)!r})))
t.start(); t.join()
print([(c.title, c.error) for c in got[0]])
"""
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.strip() == str([("make data", None), ("middle", None), ("design", None),
                                      ("mc", None)])


def test_both_front_ends_run_a_deck_under_ulimit_s_256(tmp_path):
    """mlid-batch and mlid run under `ulimit -s 256` (KB): the same report as
    without the limit."""
    import subprocess
    from conftest import BIN
    deck = tmp_path / "deck.nml"
    deck.write_text(SIM + FIT + GOOD)
    outs = {}
    for limit in ("unlimited", "256"):
        for exe, pre in (("mlid", "run "), ("mlid-batch", "")):
            run = subprocess.run(["bash", "-c", f"ulimit -s {limit}; '{BIN / exe}' {pre}'{deck}'"],
                                 capture_output=True, text=True, cwd=tmp_path)
            assert run.returncode == 0, (limit, exe, run.returncode, run.stderr[-2000:])
            outs[limit, exe] = run.stdout
    assert len(set(outs.values())) == 1 and outs["256", "mlid"].count("converged (") == 2
