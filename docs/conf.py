"""Sphinx configuration of the dcstereo documentation site (``make docs``)."""

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

import dcstereo  # noqa: E402

project = "dcstereo"
author = "the dcstereo developers"
copyright = "the dcstereo developers"  # noqa: A001 (Sphinx's name)
version = release = dcstereo.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.doctest",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "dcstereo_docs",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_templates"]
templates_path = ["_templates"]

# every cross-reference must resolve: a renamed function breaks the build
nitpicky = True
nitpick_ignore_regex = [
    # the few references to other projects' docs (json.dumps, skimage.data): no intersphinx,
    # so that the build works offline
    ("py:.*", r"(json|skimage|numpy)\..*"),
]

# MyST: the narrative pages are Markdown; $...$ for the algorithm page's equations
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# API reference: one page per public module, types from the numpydoc sections
autosummary_generate = True
autodoc_typehints = "none"
autodoc_member_order = "bysource"
autodoc_default_options = {"members": True}
numpydoc_show_class_members = False
numpydoc_xref_param_type = False

# doctests (make doctest): every page's examples run in a folder holding a small pair
doctest_global_setup = """
import os as _os
import numpy as np
import dcstereo
from doc_fixtures import make_example_folder as _make_example_folder
_os.chdir(_make_example_folder())
"""
# the docstrings' examples need their module's names: pytest --doctest-modules runs them
doctest_test_doctest_blocks = ""

html_theme = "pydata_sphinx_theme"
html_title = f"dcstereo {release}"
html_static_path = []
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_sidebars = {"**": ["sidebar-nav-bs"]}
