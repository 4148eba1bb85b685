"""Sphinx configuration of the docs site (``make docs``; tests/test_docs_site.py builds it with -W)."""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))
sys.path.insert(0, str(HERE.parent / "src"))

project = "chronofuse"
author = "the chronofuse developers"
copyright = "the chronofuse developers, MIT licence"

extensions = [
    "myst_nb",  # Markdown pages (MyST) and notebooks, executed at build time
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "apiref",
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
root_doc = "index"
# stations_table.md is the raw table the station study writes; integrity/stations.md quotes it.
exclude_patterns = ["_build", "_ext", "**.ipynb_checkpoints", "integrity/stations_table.md"]

myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3

# Notebooks are stored without outputs and run on every build; a failing cell fails it.
nb_execution_mode = "force"
nb_execution_raise_on_error = True
nb_execution_timeout = 120
nb_execution_show_tb = True
nb_merge_streams = True

# Numpy-style types ("array-like of shape (N,)") are cross-referenced word by word; "shape" is an attribute
# of two documented classes, and which one a type's word means is no question a reader has.
suppress_warnings = ["ref.python"]
autodoc_member_order = "bysource"
autodoc_typehints = "description"
napoleon_google_docstring = False
napoleon_numpy_docstring = True

html_theme = "alabaster"
html_title = "chronofuse"
