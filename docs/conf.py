"""Sphinx configuration of the nnmstop documentation site.

Build (warnings are errors, as in CI):

    sphinx-build -W --keep-going -b html docs docs/_build/html

The pages are MyST Markdown (myst-nb); the tutorial is a MyST notebook executed at every build;
the configuration reference is generated here from ``src/nnmstop/config_schema.yaml`` and the
shipped ``config/config.yaml`` (``nnmstop.docpages.configuration``) before the pages are read.
"""

from __future__ import annotations

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
REPO = DOCS.parent
# The package of this tree (not another installed copy): autodoc and the tutorial import it.
sys.path.insert(0, str(REPO / "src"))

import nnmstop  # noqa: E402
from nnmstop.docpages.configuration import write_configuration_reference  # noqa: E402

project = "nnmstop"
author = "nnmstop developers"
copyright = "nnmstop developers, MIT License"
version = release = nnmstop.__version__

extensions = [
    "myst_nb",  # MyST Markdown pages and executed MyST notebooks
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "numpydoc",
]
source_suffix = {".md": "myst-nb", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "jupyter_execute", "**.ipynb_checkpoints", "atlas_numbers.md"]  # included by atlas.md

# MyST: $...$ maths, ::: fences, and anchors for headings down to level 3 (links such as page.md#section)
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3

# The tutorial runs on every build; an error in a cell fails the build.
nb_execution_mode = "force"
nb_execution_timeout = 300
nb_execution_raise_on_error = True
nb_execution_show_tb = True
nb_merge_streams = True

# API pages: numpydoc sections; no autosummary stubs
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
autodoc_member_order = "bysource"
autodoc_typehints = "none"

html_theme = "furo"
html_title = f"nnmstop {release}"
html_static_path = []
html_last_updated_fmt = None  # no build date in the pages: two builds of one commit are the same


def _generate_pages(app):
    write_configuration_reference(
        REPO / "src" / "nnmstop" / "config_schema.yaml",
        REPO / "config" / "config.yaml",
        DOCS / "generated" / "configuration.md",
    )


def setup(app):
    app.connect("builder-inited", _generate_pages)
