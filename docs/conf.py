"""Sphinx configuration of the dualpose documentation site (``make docs``; built offline, warnings are errors)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import dualpose

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))

from dualpose_api import write_inventories  # noqa: E402

project = "dualpose"
author = "the dualpose authors"
copyright = "the dualpose authors, MIT licence"
release = version = dualpose.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.intersphinx",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_parser",
    "sphinx_design",
    "sphinx_gallery.gen_gallery",
    "dualpose_api",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = [
    "_build",
    "_ext",
    "examples/README.rst",
    "auto_examples/*.ipynb",
    "auto_examples/*.py",
    "auto_examples/*.zip",
    "auto_examples/*.md5",
    "auto_examples/*.json",
    "sg_execution_times.rst",
    # the raw output of benchmarks/bench_hand_eye.py; docs/hand-eye.md holds the same tables
    "hand-eye-table.md",
]
nitpicky = True
# private dualpose names (a private base class, a TypeVar ``_B``) in signatures have no page to link to
nitpick_ignore_regex = [(r"py:class", r"dualpose(\.\w+)*\._\w+(\.\w+)*")]
# a signature that names a type imported only for type checking (``distributed.Client``) is shown as written, so its
# private TypeVars stay unqualified
nitpick_ignore = [("py:class", "_T"), ("py:class", "_R")]

# --- autodoc, numpydoc ----------------------------------------------------------------------------
autodoc_typehints = "signature"
autodoc_member_order = "bysource"
autodoc_preserve_defaults = True
autodoc_type_aliases = {"ArrayLike": "numpy.typing.ArrayLike", "NDArray": "numpy.typing.NDArray"}
python_use_unqualified_type_names = True
add_module_names = False

numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = True
# only the words below become links in "Parameters"/"Returns" types; the rest (shapes, "optional", "of") stay text
numpydoc_xref_ignore = "all"
numpydoc_xref_aliases = {
    "ndarray": "numpy.ndarray",
    "array_like": "numpy.typing.ArrayLike",
    "ArrayLike": "numpy.typing.ArrayLike",
    "Generator": "numpy.random.Generator",
    "Path": "pathlib.Path",
    "Rotation": "scipy.spatial.transform.Rotation",
    "RigidTransform": "scipy.spatial.transform.RigidTransform",
}
numpydoc_validation_checks: set[str] = set()

# --- intersphinx: inventories written here (no network; docs/_ext/dualpose_api.py) ---------------------------------
intersphinx_mapping = write_inventories(DOCS / "_build" / "_inventories")

# --- MyST (the Markdown pages in docs/) ------------------------------------------------------------------------
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 4

# --- sphinx-gallery (docs/examples) ----------------------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r".*\.py$",
    "ignore_pattern": r"(^|/)_",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "show_memory": False,
    "reference_url": {"dualpose": None},
    # link dp.quat_mul in the examples to dualpose.algebra.quat.quat_mul, where it is documented
    "prefer_full_module": {r"dualpose"},
    "doc_module": ("dualpose",),
    "backreferences_dir": None,
    "min_reported_time": 0,
    "write_computation_times": False,
    "abort_on_example_error": True,
    "matplotlib_animations": False,
    "plot_gallery": os.environ.get("DUALPOSE_DOCS_GALLERY", "True"),
}

# --- HTML --------------------------------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"dualpose {release}"
html_static_path = ["_static"]
html_css_files = ["dualpose.css"]
html_show_sourcelink = False
html_theme_options = {
    "navbar_align": "left",
    "show_toc_level": 2,
    "navigation_with_keys": False,
    # the gallery's pages without the right-hand column: their code needs the width
    "secondary_sidebar_items": {"*": ["page-toc"], "api/*": ["page-toc"], "auto_examples/*": []},
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_sidebars = {"index": [], "getting-started": []}
