"""The deck reference page, made from the core's own tables when the docs are built.

The core says which groups a deck has, which jobs read each and the names each
takes (mlid_deck's GROUP_KEYS and JOB_GROUPS, through ``mlid_deck_groups``), and
for the options their kind, default and choices (mlid_options, through
``mlid_option_info``, ``mlid_default_options``, ``mlid_option_get`` and
``mlid_option_choices``).  ``docs/reference/deck_items.txt`` says what each name
means.  A name the core has and the file does not, or the other way round, or a
default the file gives for an option, stops the build: the page cannot fall
behind the reader.  tests/test_docs.py checks the page against the core.
"""

from pathlib import Path

HERE = Path(__file__).resolve().parent
ITEMS = HERE.parent / "reference" / "deck_items.txt"
PAGE = HERE.parent / "reference" / "deck.md"

#: The groups whose names may be options of the core's option table (&model
#: carries input_hold and substeps; &design's method is not the estimator's).
OPTION_GROUPS = ("model", "estimate")


class DeckReferenceError(Exception):
    """The meanings file and the core's tables disagree."""


def core_groups():
    """[(group, [jobs that read it], [its names])] as the core's deck reader defines them."""
    from mlid._bridge import api, text
    out = []
    for line in text(api.mlid_deck_groups()).splitlines():
        group, jobs, keys = line.split("|")
        out.append((group, jobs.split(), keys.split()))
    return out


def core_options():
    """{name: (kind, default as the core writes it, [choices])} of the core's option table."""
    from mlid._bridge import api, text
    iopt, ropt = api.mlid_default_options()
    out, k = {}, 1
    while True:
        name, kind = (text(v) for v in api.mlid_option_info(k))
        if not name:
            return out
        out[name] = (kind, text(api.mlid_option_get(iopt, ropt, name)),
                     text(api.mlid_option_choices(name)).split())
        k += 1


def read_items(path=ITEMS):
    """The meanings file's entries: [(group, [names], default or None, meaning)]."""
    entries, block = [], []
    lines = [s for s in Path(path).read_text(encoding="utf-8").splitlines()
             if not s.startswith("#")]
    for line in lines + [""]:
        if line.strip():
            block.append(line)
            continue
        if not block:
            continue
        head, rest = block[0], block[1:]
        if not head.startswith("[") or "]" not in head:
            raise DeckReferenceError(f"{path}: an entry starts with [group], not {head!r}")
        group, names = head[1:].split("]", 1)
        default = None
        if rest and rest[0].startswith("default: "):
            default, rest = rest[0][len("default: "):], rest[1:]
        names = [n.strip() for n in names.split(",") if n.strip()]
        entries.append((group.strip(), names, default, " ".join(rest)))
        block = []
    return entries


def _cell(s):
    """Text for a Markdown table cell: a | would end the cell."""
    return s.replace("|", "\\|")


def _option_default(kind, value, choices):
    """An option's default and choices as the deck writes them."""
    if kind == "bool":
        return f"`.{value}.`"
    if kind == "choice":
        return f"`'{value}'` (or " + ", ".join(f"`'{c}'`" for c in choices if c != value) + ")"
    if kind == "real":
        return f"`{float(value):g}`"
    return f"`{value}`"


def check(groups, options, entries):
    """Raise DeckReferenceError where the meanings file and the core disagree."""
    known = {g: set(keys) for g, _, keys in groups}
    seen = {}
    problems = []
    for group, names, default, _ in entries:
        if group not in known:
            problems.append(f"[{group}]: the core's deck reader has no group &{group}")
            continue
        for name in names:
            if name not in known[group]:
                problems.append(f"[{group}] {name}: &{group} takes no name {name}")
            if (group, name) in seen:
                problems.append(f"[{group}] {name}: given twice")
            seen[group, name] = True
        is_option = group in OPTION_GROUPS and names and all(n in options for n in names)
        if is_option and default is not None:
            problems.append(f"[{group}] {', '.join(names)}: an option's default is the core's; "
                            "give none here")
    for group, keys in known.items():
        for key in keys:
            if (group, key) not in seen:
                problems.append(f"&{group} {key}: the core's reader takes it; "
                                f"say what it means in {ITEMS.name}")
    if problems:
        raise DeckReferenceError("deck reference: " + "; ".join(problems))


def make_page(groups=None, options=None, entries=None):
    """The deck reference page (MyST Markdown) from the core's tables and the meanings."""
    groups = core_groups() if groups is None else groups
    options = core_options() if options is None else options
    entries = read_items() if entries is None else entries
    check(groups, options, entries)
    out = ["# Deck reference", "",
           "Every group of a deck and every name it takes, with its default. This page is "
           "made when the docs are built: the groups, the jobs that read each and the "
           "names each takes come from the core's deck reader (`GROUP_KEYS` and "
           "`JOB_GROUPS` in `fortran/case/mlid_deck.f90`), the options' defaults and "
           "choices from the core's option table (`fortran/estimation/mlid_options.f90`), "
           "and what each name means from `docs/reference/deck_items.txt`. The rules every "
           "group follows (values, lists, comments, limits) are in the guide's "
           "[Decks](../guide/decks.md) page.", ""]
    for group, jobs, keys in groups:
        mine = [e for e in entries if e[0] == group]
        out += [f"## &{group}", "",
                ("Read by job " if len(jobs) == 1 else "Read by jobs ")
                + ", ".join(f"`'{j}'`" for j in jobs) + ".", ""]
        out += [m + "\n" for g, names, d, m in mine if not names]
        out += ["| name | default | meaning |", "|---|---|---|"]
        for _, names, default, meaning in (e for e in mine if e[1]):
            if group in OPTION_GROUPS and all(n in options for n in names):
                shown = [_option_default(*options[n]) for n in names]
                default = shown[0] if len(set(shown)) == 1 else "; ".join(
                    f"`{n}` {d}" for n, d in zip(names, shown))
            cells = [", ".join(f"`{n}`" for n in names), default or "", meaning]
            out.append("| " + " | ".join(_cell(c) for c in cells) + " |")
        out.append("")
    return "\n".join(out)


def write_page(app=None):
    """Write the page where the toctree finds it, only when it changed (Sphinx
    reads a changed source again)."""
    text = make_page()
    if not PAGE.exists() or PAGE.read_text(encoding="utf-8") != text:
        PAGE.write_text(text, encoding="utf-8")


def setup(app):
    app.connect("builder-inited", write_page)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
