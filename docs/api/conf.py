"""Sphinx configuration of the API reference, generated from the docstrings.

Build (Debian: ``apt-get install python3-sphinx``; the venv sees system packages)::

    .venv/bin/python -m sphinx -b html docs/api build/api

then open ``build/api/index.html``.
"""
project = "elastica_petsc"
extensions = ["sphinx.ext.autodoc", "sphinx.ext.napoleon"]
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_member_order = "bysource"
autodoc_typehints = "description"
html_theme = "alabaster"
exclude_patterns = ["_build"]


def _plain_bars(app, what, name, obj, options, lines):
    """The docstrings write norms as |x - y| (plain text, not reST substitutions)."""
    lines[:] = [line.replace("|", "\\|") for line in lines]


def setup(app):
    app.connect("autodoc-process-docstring", _plain_bars)
