"""The documentation cannot drift from the code: every Python example of the README and of the
site's guide runs, on the built-in figure written as the files the examples name."""

import re
from pathlib import Path

import pytest

from darcyan.geometry import synthetic
from darcyan.io.mesh_files import save_mesh

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ["README.md", "docs/getting-started.md", "docs/guide/python.md"]
README_LIMIT = 12_000  # bytes: a newcomer's page; results and history live in docs/


def python_blocks(path: Path) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", path.read_text(), flags=re.S | re.M)


@pytest.mark.slow
@pytest.mark.parametrize("page", EXAMPLES)
def test_every_python_example_runs(page, tmp_path, monkeypatch, capsys):
    blocks = python_blocks(ROOT / page)
    assert blocks, f"{page}: no Python example"
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("DARCYAN_CACHE", str(tmp_path / "cache"))
    for pose in (0, 1):  # the files the examples name
        save_mesh(synthetic.figure(pose, subdivisions=4), tmp_path / f"cat{pose}.off")
    for block in blocks:
        exec(compile(block, f"{page} example", "exec"), {"__name__": "__docs__"})
    assert "source_vertex,target_vertex,distance" in capsys.readouterr().out  # each page prints matches


def test_the_readme_is_short_and_keeps_the_quick_start():
    text = (ROOT / "README.md").read_text()
    assert len(text.encode()) <= README_LIMIT
    quick_start = text.split("## Quick start", 1)[1].split("```bash\n", 1)[1].split("```", 1)[0]
    assert quick_start.splitlines() == ["pip install . && darcyan demo",
                                        "pip install '.[test]' && python -m pytest -q"]
    for link in re.findall(r"\]\(((?!http)[^)#]+)", text):  # every link of the README names a file
        assert (ROOT / link).exists(), link
