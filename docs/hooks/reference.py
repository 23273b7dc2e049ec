"""mkdocs hook: the command-line and settings references, generated from the code.

``<!-- darcyan:cli -->`` becomes every command's ``--help``; ``<!-- darcyan:settings -->`` a table
per settings class of every field: name, default, stage and the field's documentation (the
``Attributes:`` section of the class's docstring). Nothing is written twice.
"""

from __future__ import annotations

import dataclasses
import inspect


def on_page_markdown(markdown: str, page, config, files) -> str:
    if "<!-- darcyan:cli -->" in markdown:
        markdown = markdown.replace("<!-- darcyan:cli -->", cli_reference())
    if "<!-- darcyan:settings -->" in markdown:
        markdown = markdown.replace("<!-- darcyan:settings -->", settings_reference())
    return markdown


def cli_reference() -> str:
    import argparse

    from darcyan.cli import build_parser

    parser = build_parser()
    parts = ["```text", _help(parser), "```"]
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, sub in commands.choices.items():
        parts += [f"## darcyan {name}", "", "```text", _help(sub), "```", ""]
    return "\n".join(parts)


def _help(parser) -> str:
    import os

    os.environ["COLUMNS"] = "100"  # argparse wraps to the terminal: the same page on every machine
    return parser.format_help().rstrip()


def settings_reference() -> str:
    from darcyan.config import SECTIONS, DarcyanConfig

    parts = [_table("DarcyanConfig", DarcyanConfig, "")]
    parts += [_table(f"DarcyanConfig.{name}", cls, f"{name}.") for name, cls in SECTIONS.items()]
    return "\n\n".join(parts)


def _table(title: str, cls, prefix: str) -> str:
    from darcyan.config import field_docs

    docs = field_docs(cls)
    rows = [f"## {title}", "", inspect.cleandoc(cls.__doc__ or "").split("\n\n")[0].replace("\n", " "), "",
            "| setting | default | stage | what it does |", "| --- | --- | --- | --- |"]
    for field in dataclasses.fields(cls):
        default = field.default if field.default is not dataclasses.MISSING else field.default_factory()
        if dataclasses.is_dataclass(default):
            continue  # a section: its own table
        stage = field.metadata.get("stage", "dense")
        text = docs.get(field.name, "").replace("|", "\\|")
        rows.append(f"| `{prefix}{field.name}` | `{default!r}` | {stage} | {text} |")
    return "\n".join(rows)
