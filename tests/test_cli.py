"""The command line: output contracts and one-line errors with exit status 2."""

import csv
import io
import subprocess
import sys

import numpy as np
import pytest
from conftest import run_cli as run

from darcyan.geometry import synthetic
from darcyan.io.mesh_files import save_mesh

pytestmark = pytest.mark.usefixtures("private_cache")  # each test its own $DARCYAN_CACHE


@pytest.fixture(scope="module")
def pose_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("poses")
    paths = []
    for pose in (0, 1):
        path = folder / f"figure{pose}.off"
        save_mesh(synthetic.figure(pose), path)
        paths.append(path)
    return paths


def test_match_writes_the_csv_contract(capsys, pose_files, tmp_path):
    code, out, err = run(capsys, "match", *pose_files)
    assert code == 0
    rows = list(csv.DictReader(io.StringIO(out)))
    assert list(rows[0]) == ["source_vertex", "target_vertex", "distance"]
    assert len(rows) == 5
    for row in rows:
        assert float(row["distance"]) >= 0
    # The figure's truth in the files' numbering: the sources are its five limb tips, one each,
    # and each target is its source's vertex (same numbering in both poses) within 0.05 sqrt(area).
    source = np.array([int(row["source_vertex"]) for row in rows])
    target = np.array([int(row["target_vertex"]) for row in rows])
    poses = synthetic.figure(0), synthetic.figure(1)
    assert ((0 <= source) & (source < poses[0].n_vertices) & (0 <= target) & (target < poses[1].n_vertices)).all()
    tips = synthetic.figure_tips()
    to_tips = np.linalg.norm(poses[0].vertices[source][:, None] - poses[0].vertices[tips][None], axis=2)
    assert sorted(to_tips.argmin(axis=1)) == list(range(len(tips)))
    assert (to_tips.min(axis=1) < 0.05 * np.sqrt(poses[0].area())).all()
    errors = np.linalg.norm(poses[1].vertices[target] - poses[1].vertices[source], axis=1)
    assert (errors < 0.05 * np.sqrt(poses[1].area())).all(), errors
    # The same to a file, and again from the cache.
    out_file = tmp_path / "m.csv"
    assert run(capsys, "match", *pose_files, "-o", out_file)[0] == 0
    assert out_file.read_text() == out
    assert run(capsys, "match", *pose_files)[1] == out


def test_features_and_describe(capsys, pose_files, tmp_path):
    code, out, _ = run(capsys, "features", pose_files[0])
    rows = list(csv.DictReader(io.StringIO(out)))
    assert code == 0 and list(rows[0]) == ["vertex", "agd"] and len(rows) == 5
    npz = tmp_path / "d.npz"
    assert run(capsys, "describe", pose_files[0], "-o", npz, "--levels", "4")[0] == 0
    data = np.load(npz)
    assert data["descriptor"].shape == (5, 8)
    np.testing.assert_array_equal(sorted(data["vertex"]), sorted(int(r["vertex"]) for r in rows))
    csv_path = tmp_path / "d.csv"
    assert run(capsys, "describe", pose_files[0], "-o", csv_path)[0] == 0
    assert csv_path.read_text().startswith("vertex,agd,k1max,k1min,k2max")


def test_demo_reports_correct_matches(capsys):
    code, out, _ = run(capsys, "demo")
    assert code == 0 and "5 of 5 matches correct" in out


BAD = {
    "missing": (None, "no such file"),
    "unknown.dxf": ("0\nSECTION\n", "unsupported file type"),
    "points.xyz": ("1 2 3\n", "1 points and no faces: a triangle mesh is needed"),
    "header.off": ("OFF\n4 x 0\n", "integers"),
    "nan.off": ("OFF\n4 2 0\n0 0 0\nnan 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n", "NaN"),
    "range.off": ("OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 7\n", "out of range"),
    "tiny.off": ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "too small"),
    # smoothed as vertex noise, two triangles shrink to no area: the error says why
    "square.off": ("OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n", "too small or coarse for a Darcyan grid"),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_input_is_one_line_and_exit_2(capsys, tmp_path, name, pose_files):
    text, message = BAD[name]
    path = tmp_path / name
    if text is not None:
        path.write_text(text)
    code, out, err = run(capsys, "match", path, pose_files[0])
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("darcyan: error: ") and str(path) in lines[0]
    assert message in lines[0]


def test_tetrahedron_is_too_small_for_a_grid(capsys, tmp_path):
    path = tmp_path / "tetra.off"
    path.write_text("OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n")
    code, _, err = run(capsys, "features", path)
    assert code == 2 and len(err.strip().splitlines()) == 1 and str(path) in err


def test_installed_entry_point_has_no_traceback(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "darcyan", "match", tmp_path / "a.off", tmp_path / "b.off"],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert proc.stderr.strip().count("\n") == 0


@pytest.mark.slow
def test_two_worker_processes_give_what_one_process_gives(capsys, pose_files, tmp_path):
    one = run(capsys, "match", *pose_files, "--jobs", "1", "--no-cache")
    two = run(capsys, "match", *pose_files, "--jobs", "2", "--no-cache")
    assert one[0] == two[0] == 0 and one[1] == two[1] and len(one[1].splitlines()) == 6
    # What a worker warns or refuses reaches the command line as in one process.
    ball = synthetic.icosphere(2, 0.2)
    figure = synthetic.figure(1)
    two_parts = tmp_path / "two_parts.off"
    save_mesh(type(figure)(np.vstack([figure.vertices, ball.vertices + 10.0]),
                           np.vstack([figure.faces, ball.faces + figure.n_vertices])), two_parts)
    code, out, err = run(capsys, "match", pose_files[0], two_parts, "--jobs", "2")
    assert code == 0 and out == two[1]
    assert err.count("darcyan: warning:") == 1 and f"{two_parts}: 2 connected components" in err
    broken = tmp_path / "broken.off"
    broken.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\nnan 1 0\n3 0 1 2\n")
    code, out, err = run(capsys, "match", pose_files[0], broken, "--jobs", "2", "--no-cache")
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1 and str(broken) in err


def test_paper_preset_and_options_beside_it():
    from darcyan import DarcyanConfig
    from darcyan.cli import _config, build_parser

    parse = build_parser().parse_args
    assert _config(parse(["match", "a.off", "b.off"])) == DarcyanConfig()
    assert _config(parse(["match", "a.off", "b.off", "--paper"])) == DarcyanConfig.paper()
    assert DarcyanConfig.paper().matching == "nearest" and DarcyanConfig.paper().agd_smoothing == 0
    mixed = _config(parse(["bench", "data", "--paper", "--radius", "0.08", "--matching", "one-to-one"]))
    assert mixed == DarcyanConfig.paper(radius=0.08, matching="one-to-one")


@pytest.mark.parametrize("argv", [["match", "a.off", "b.off", "-o", "{out}"], ["features", "a.off", "-o", "{out}"],
                                  ["describe", "a.off", "-o", "{out}"]])
@pytest.mark.parametrize("out, words", [("m.xyz", "unknown output format '.xyz'"),
                                        ("missing/m.csv", "cannot write (no such folder)")])
def test_the_output_is_checked_before_any_work(capsys, tmp_path, argv, out, words):
    """The input files do not exist: the error names the output, so it was checked first."""
    output = str(tmp_path / out)
    code, stdout, err = run(capsys, *[a.format(out=output) for a in argv])
    assert code == 2 and stdout == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"darcyan: error: {output}: {words}"), err
    assert "a.off" not in err
