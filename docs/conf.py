"""Sphinx configuration of the auv-hinf documentation.

Build with ``make docs`` (``sphinx-build -W``: every warning is an error). The design
notebooks are rendered as they are stored in ``notebooks/``, without outputs and without
executing them; ``make test`` executes them with nbmake.
"""

from __future__ import annotations

import pkgutil
import re
import shutil
import sys
from pathlib import Path
from typing import Any

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))

import auv_hinf  # noqa: E402

project = "auv-hinf"
author = "auv-hinf developers"
copyright = f"2026, {author}"
version = release = auv_hinf.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_nb",
]

# -- sources ---------------------------------------------------------------------------
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "**.ipynb_checkpoints"]

# The notebooks live in ../notebooks (nbmake runs them there); Sphinx only reads files
# below docs/, so they are copied (with their timestamps, so incremental builds work)
# into docs/notebooks/, which is generated and ignored by git.
_NB_SRC, _NB_DST = ROOT / "notebooks", DOCS / "notebooks"
_NB_DST.mkdir(exist_ok=True)
for _stale in _NB_DST.glob("*.ipynb"):
    if not (_NB_SRC / _stale.name).exists():
        _stale.unlink()
for _nb in sorted(_NB_SRC.glob("*.ipynb")):
    shutil.copy2(_nb, _NB_DST / _nb.name)

# -- MyST and myst-nb ------------------------------------------------------------------
nb_execution_mode = "off"  # stored without outputs; executed by nbmake in `make test`
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# -- API reference ---------------------------------------------------------------------
# One page per public module, found by walking the package, so a new module is documented
# without editing the docs. (autosummary is not used: it resolves ``auv_hinf.design.crosscheck``
# to the function the package re-exports under that name, not to the module.)
_API = DOCS / "api" / "generated"
_API.mkdir(parents=True, exist_ok=True)
_modules = sorted(
    m.name
    for m in pkgutil.walk_packages(auv_hinf.__path__, "auv_hinf.")
    if not any(part.startswith("_") for part in m.name.split("."))
)
for _stale in _API.glob("*.rst"):
    if _stale.stem not in _modules:
        _stale.unlink()
for _mod in _modules:
    _title = f"``{_mod}``"
    _text = f"{_title}\n{'=' * len(_title)}\n\n.. automodule:: {_mod}\n   :members:\n   :show-inheritance:\n"
    _page = _API / f"{_mod}.rst"
    if not _page.exists() or _page.read_text() != _text:  # unchanged pages keep their mtime
        _page.write_text(_text)
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "none"  # numpydoc sections state the types
autodoc_preserve_defaults = True
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# -- HTML ------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"auv-hinf {release}"
html_static_path: list[str] = []
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
html_sidebars = {"**": ["sidebar-nav-bs"]}

# Docstrings write absolute values as |u| or |lam| in plain text; in reStructuredText that
# is substitution syntax. Escape such bars outside literals so they render as written.
_LITERAL = re.compile(r"(``.*?``|`[^`]*`)")
_ABS = re.compile(r"(?<![\\|\w])\|([^\s|`](?:[^|`]*?[^\s|`])?)\|(?![|A-Za-z0-9])")


def _escape_abs_bars(app: Any, what: str, name: str, obj: Any, options: Any, lines: list[str]) -> None:
    for i, line in enumerate(lines):
        parts = _LITERAL.split(line)
        lines[i] = "".join(p if k % 2 else _ABS.sub(r"\\|\1\\|", p) for k, p in enumerate(parts))


def setup(app: Any) -> None:
    app.connect("autodoc-process-docstring", _escape_abs_bars)
