"""griffe extension: the Sphinx roles of darcyan's docstrings as Markdown code spans.

The docstrings name other objects the way Sphinx does (``:func:`~darcyan.dense.maps.dense_map```);
mkdocstrings renders Markdown, where that would show as it is written. Each role becomes the code
span of the name it shows (the last part after ``~``), and reST's double backquotes single ones.
"""

from __future__ import annotations

import re

import griffe

ROLE = re.compile(r":(?:class|func|meth|attr|mod|data|exc|obj):`(~?)([^`]+)`")


def _markdown(text: str) -> str:
    text = ROLE.sub(lambda m: f"`{m.group(2).rsplit('.', 1)[-1] if m.group(1) else m.group(2)}`", text)
    return text.replace("``", "`")


class SphinxRoles(griffe.Extension):
    def on_instance(self, *, obj, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = _markdown(obj.docstring.value)
