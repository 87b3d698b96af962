"""Pages made from the repository's own text when the docs are built.

- Getting started: the README's "Two commands" and "A first fit", taken from
  README.md itself (the one place they are written), written to
  docs/getting_started.md.
- Links to repository files outside docs/ (a case's README, the README itself):
  the site holds only its own pages, so such a link becomes the file's path as
  code text, in every page as Sphinx reads it.  A link to a page of docs/ is
  kept, made relative to the page that holds it.
"""

import os
import re
from pathlib import Path

DOCS = Path(__file__).resolve().parent.parent
ROOT = DOCS.parent
README = ROOT / "README.md"
PAGE = DOCS / "getting_started.md"
#: The README's sections that make the page, in order.
SECTIONS = ("Two commands", "A first fit")
LINK = re.compile(r"(?<!!)\[([^\]]+)\]\(([^)\s]+)\)")


def sections(text, names):
    """The README's '## name' sections, each up to the next '## '."""
    parts = re.split(r"^## ", text, flags=re.M)
    found = {p.split("\n", 1)[0].strip(): p.split("\n", 1)[1] for p in parts[1:]}
    missing = [n for n in names if n not in found]
    if missing:
        raise ValueError(f"README.md has no section {missing[0]!r}")
    return [(n, found[n].strip()) for n in names]


def relink(text, source, page=None):
    """Links of Markdown text written at path source, for the page at path page
    (source itself unless given): to a page of docs/, relative to page; to any
    other repository file, its path from the repository's root as code."""
    page = source if page is None else page
    def one(m):
        label, target = m.group(1), m.group(2)
        if re.match(r"[a-z]+:", target) or target.startswith("#"):
            return m.group(0)
        path = (source.parent / target.split("#")[0]).resolve()
        try:
            inside = path.relative_to(DOCS)
        except ValueError:
            inside = None
        if inside is not None and path.suffix == ".md" and path.exists():
            anchor = target[len(target.split("#")[0]):]
            return f"[{label}]({os.path.relpath(path, page.parent)}{anchor})"
        rel = path.relative_to(ROOT).as_posix() if path.is_relative_to(ROOT) else target
        if label.strip("`") == rel:
            return f"`{rel}`"
        return f"{label} (`{rel}`)"
    return LINK.sub(one, text)


def getting_started():
    """The Getting started page from the README."""
    text = README.read_text(encoding="utf-8")
    out = ["# Getting started", "",
           "What to install and a first fit, from the README (`README.md`, the one place "
           "they are written).", ""]
    for name, body in sections(text, SECTIONS):
        out += [f"## {name}", "", body, ""]
    return relink("\n".join(out), README, PAGE)


def write_pages(app=None):
    text = getting_started()
    if not PAGE.exists() or PAGE.read_text(encoding="utf-8") != text:
        PAGE.write_text(text, encoding="utf-8")


def source_read(app, docname, source):
    path = Path(app.env.doc2path(docname))
    if path.suffix == ".md":
        source[0] = relink(source[0], path)


def setup(app):
    app.connect("builder-inited", write_pages)
    app.connect("source-read", source_read)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
