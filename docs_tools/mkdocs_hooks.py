"""MkDocs hooks of the documentation site (mkdocs.yml ``hooks``).

The code's docstrings name other code with Sphinx roles (``:class:`System```, ``:func:`~harness.run.load```),
which mkdocstrings renders as the role's word followed by the name in code: the role's word is dropped here, and
a leading ``~`` (Sphinx's "show the last part only") shortens the name as Sphinx would."""
from __future__ import annotations

import re

_ROLE = re.compile(r":(?:class|func|meth|mod|data|attr|exc|obj):<code>(~?)([^<]*)</code>")


def _name(match: re.Match) -> str:
    short, name = match.groups()
    return f"<code>{name.rpartition('.')[2] if short else name}</code>"


def on_page_content(html: str, **kwargs) -> str:
    return _ROLE.sub(_name, html)
