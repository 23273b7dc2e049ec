"""The suite's own rules (tests/conftest.py): a test needs ../shared/data exactly when it uses the
``tosca`` fixture, and then carries the ``data`` marker, so that ``-m "not data"`` runs without the
data and ``-m data`` runs everything that needs it."""

from __future__ import annotations

import ast
from pathlib import Path

TESTS = Path(__file__).resolve().parent
# What finding the data without the fixture would look like in a test module.
WAYS_TO_THE_DATA = ("DARCYAN_DATA", "shared/data", "shared\\data")


def test_the_data_marker_is_on_exactly_the_tests_using_the_tosca_fixture(request):
    """Over the tests of this run (every test in ``python -m pytest``; run alone, this test sees
    only itself); the ``-m`` filters keep the rule true on what they keep."""
    wrong = []
    for item in request.session.items:
        uses = "tosca" in getattr(item, "fixturenames", ())
        marked = item.get_closest_marker("data") is not None
        if uses != marked:
            wrong.append(f"{item.nodeid}: " + ("uses tosca, no data marker" if uses else "data marker, no tosca"))
    assert not wrong, wrong


def ways_to_the_data(source: str) -> list[str]:
    """Places in a module's ``source`` that find the data by themselves: ``data_dir`` (conftest's
    helper behind the fixture), or a string naming ``$DARCYAN_DATA`` or ``shared/data`` outside
    docstrings (comments are not in the syntax tree)."""
    tree = ast.parse(source)
    docstrings = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                docstrings.add(id(first.value))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and node.id == "data_dir" or isinstance(node, ast.Attribute) \
                and node.attr == "data_dir" or isinstance(node, ast.ImportFrom) \
                and any(a.name == "data_dir" for a in node.names):
            found.append(f"line {node.lineno}: data_dir")
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings \
                and any(word in node.value for word in WAYS_TO_THE_DATA):
            found.append(f"line {node.lineno}: {node.value!r}")
    return found


def test_the_data_is_reached_only_through_the_tosca_fixture():
    """A test module that found the data by itself would escape the ``data`` marker."""
    this = Path(__file__).name  # names the ways above, to look for them
    found = {p.name: ways for p in sorted(TESTS.glob("test_*.py")) if p.name != this
             and (ways := ways_to_the_data(p.read_text()))}
    assert not found, found
    # The search finds each way when it is there.
    caught = ways_to_the_data('"""About shared/data."""\nfrom conftest import data_dir\n'
                              'def test_x():\n    """Uses ../shared/data."""\n    root = conftest.data_dir()\n'
                              '    a = data_dir() / "x"\n    b = os.environ["DARCYAN_DATA"]\n'
                              '    c = Path("../shared/data/tosca-5k")\n')
    assert sorted(int(place.split(":")[0][5:]) for place in caught) == [2, 5, 6, 7, 8], caught
