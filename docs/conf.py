"""Sphinx configuration of mlid's documentation site (make docs).

Pages are Markdown (MyST); the Python API comes from the docstrings (autodoc,
autosummary, numpydoc); the gallery's figures are made when the site is built
(sphinx-gallery, examples/); the deck reference and Getting started are made
from the core and the README (_ext/); the Fortran API is FORD's (fortran_api.md,
run by the Makefile into _build/html/fortran).
"""

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

import mlid  # noqa: E402  the installed package, as the tests use it

project = "mlid"
author = "the mlid developers"
copyright = "the mlid developers"
release = mlid.__version__
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
    "deck_reference",
    "repo_pages",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "fortran_api.md", "reference/deck_items.txt", "examples/README.txt",
                    "**/README.md"]
myst_enable_extensions = ["dollarmath"]
myst_heading_anchors = 3

# The API pages: one per public name of mlid.__all__ (api.rst).
autosummary_generate = True
autodoc_default_options = {"members": True, "inherited-members": False}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False

sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "ignore_pattern": r"__init__\.py|_records\.py",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "reset_modules": ("matplotlib",),
    "capture_repr": (),
}

html_theme = "pydata_sphinx_theme"
html_title = "mlid"
html_theme_options = {
    "navbar_align": "left",
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
html_sidebars = {"**": ["sidebar-nav-bs"]}
html_static_path = []
