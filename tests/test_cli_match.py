"""`darcyan match` for one source and many targets, its output formats, progress and threads."""

import csv
import io
import json

import numpy as np
import pytest
from conftest import run_cli as run

from darcyan.geometry import synthetic
from darcyan.io.mesh_files import save_mesh

pytestmark = pytest.mark.usefixtures("private_cache")  # each test its own $DARCYAN_CACHE

SUBDIVISIONS = 4  # 2,562-vertex figures: fast


@pytest.fixture(scope="module")
def figures(tmp_path_factory):
    """The figure in poses 0, 1 and 2 (one vertex numbering: the tips are the true matches)."""
    folder = tmp_path_factory.mktemp("figures")
    paths = []
    for pose in (0, 1, 2):
        paths.append(folder / f"figure{pose}.off")
        save_mesh(synthetic.figure(pose, SUBDIVISIONS), paths[-1])
    return paths


def test_one_source_against_many_targets_equals_the_pairs_one_by_one(capsys, figures):
    code, out, err = run(capsys, "match", figures[0], figures[1], figures[2])
    assert code == 0, err
    rows = list(csv.DictReader(io.StringIO(out)))
    assert list(rows[0]) == ["target", "source_vertex", "target_vertex", "distance"]
    assert {r["target"] for r in rows} == {str(figures[1]), str(figures[2])}
    for target in figures[1:]:
        alone = list(csv.DictReader(io.StringIO(run(capsys, "match", figures[0], target)[1])))
        mine = [{k: v for k, v in r.items() if k != "target"} for r in rows if r["target"] == str(target)]
        assert mine == alone
        # the poses share one numbering: each match lands on the limb of the source vertex's own
        # copy (within 0.1 sqrt(area), about a hand's length; another tip is several times farther)
        mesh = synthetic.figure(int(target.stem[-1]), SUBDIVISIONS)
        gap = [np.linalg.norm(mesh.vertices[int(r["source_vertex"])] - mesh.vertices[int(r["target_vertex"])])
               for r in alone]
        assert max(gap) < 0.1 * np.sqrt(mesh.area())


def test_json_output_by_suffix_or_format(capsys, figures, tmp_path):
    path = tmp_path / "m.json"
    assert run(capsys, "match", figures[0], figures[1], "-o", path)[0] == 0
    record = json.loads(path.read_text())
    assert record["source"] == str(figures[0]) and record["target"] == str(figures[1])
    assert len(record["matches"]) == 5
    csv_rows = list(csv.DictReader(io.StringIO(run(capsys, "match", figures[0], figures[1])[1])))
    assert [int(m["target_vertex"]) for m in record["matches"]] == [int(r["target_vertex"]) for r in csv_rows]
    code, out, _ = run(capsys, "match", figures[0], figures[1], figures[2], "--format", "json")
    assert code == 0 and [r["target"] for r in json.loads(out)] == [str(figures[1]), str(figures[2])]


@pytest.mark.slow
def test_dense_maps_of_several_targets_go_to_a_folder_with_progress(capsys, figures, tmp_path):
    folder = tmp_path / "maps"
    code, _, err = run(capsys, "match", figures[0], figures[1], figures[2], "--dense", "-o", folder)
    assert code == 0, err
    assert "dense map: zoomout" in err  # progress lines on stderr
    n = synthetic.figure(0, SUBDIVISIONS).n_vertices
    for target in figures[1:]:
        rows = np.loadtxt(folder / f"{target.stem}.csv", delimiter=",", skiprows=1, dtype=np.int64)
        assert rows.shape == (n, 2) and np.array_equal(rows[:, 0], np.arange(n))
        assert (rows[:, 1] == rows[:, 0]).mean() > 0.5  # one numbering: most vertices map onto themselves
    code, _, err = run(capsys, "match", figures[0], figures[1], "--dense", "-o", tmp_path / "q.csv", "--quiet")
    assert code == 0 and "dense map" not in err
    code, _, err = run(capsys, "match", figures[0], figures[1], figures[2], "--dense")
    assert code == 2 and "-o FOLDER" in err


def test_pictures_and_truth_take_one_target_and_threads_are_checked(capsys, figures, tmp_path):
    code, _, err = run(capsys, "match", figures[0], figures[1], figures[2], "--truth", "identity")
    assert code == 2 and "one target" in err
    assert run(capsys, "match", figures[0], figures[1], "--threads", "2")[0] == 0
    code, _, err = run(capsys, "match", figures[0], figures[1], "--threads", "-1")
    assert code == 2 and "--threads" in err


def test_dense_maps_of_targets_with_one_name_are_refused_before_any_work(capsys, figures, tmp_path):
    other = tmp_path / "elsewhere"
    other.mkdir()
    twin = other / figures[1].name
    twin.write_bytes(figures[1].read_bytes())
    code, _, err = run(capsys, "match", figures[0], figures[1], twin, "--dense", "-o", tmp_path / "maps")
    assert code == 2 and "figure1" in err and len(err.strip().splitlines()) == 1
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    code, _, err = run(capsys, "match", figures[0], figures[1], figures[2], "--dense", "-o", blocker)
    assert code == 2 and "cannot make the folder" in err


def test_the_seed_verdict_says_how_the_map_was_started():
    from darcyan.cli import _seed_verdict
    from darcyan.dense.seeds import seed_check

    kept = seed_check(0, {0: 0.10, 1: 0.20, 4: 0.101}, 0.04, rival=4).as_dict()
    assert "hold against their alternatives" in _seed_verdict(kept)
    assert "weighed against it and did not score better" in _seed_verdict(kept)
    refused = seed_check(0, {0: 0.10, 1: 0.20, 4: 0.05}, 0.04, rival=4).as_dict()  # scored better, alignment said no
    assert "scored better, but its map was not taken (the alignment followed it less closely" in _seed_verdict(refused)
    assert "scores close" not in _seed_verdict(refused)
    alone = seed_check(0, {0: 0.10, 1: 0.101}, 0.04, rival=1).as_dict()  # one matching and the rival
    assert _seed_verdict(alone).startswith("the feature matches, no alternative matching to weigh them against; "
                                           "a start without")
    taken = seed_check(4, {0: 0.10, 1: 0.20, 4: 0.05}, 0.04, "spectral", "axes ++", rival=4).as_dict()
    assert "the map from the matchings was not trusted" in _seed_verdict(taken) and "axes ++" in _seed_verdict(taken)
    fallback = seed_check(2, {2: 0.05}, 0.04, "spectral", "spectral +-+-").as_dict()
    assert "fewer than 3 consistent ones" in _seed_verdict(fallback) and "rival" not in fallback
    assert "by_checks" not in taken and "by_checks" not in kept  # recorded only when true
    import dataclasses

    checked = dataclasses.replace(seed_check(4, {0: 0.10, 1: 0.20, 4: 0.12}, 0.04, "spectral", "axes ++", rival=4),
                                  by_checks=True).as_dict()  # its signature no better: taken by its map's checks
    said = _seed_verdict(checked)
    assert checked["by_checks"] is True and "agrees better with its landmarks' orientation" in said
    assert "clearly better" not in said and "scores close" not in said


def test_the_seed_verdict_says_the_map_was_made_on_copies_cut_open_at_their_handles():
    import dataclasses

    from darcyan.cli import _seed_verdict
    from darcyan.dense.seeds import seed_check

    plain = seed_check(0, {0: 0.10, 1: 0.20}, 0.04)
    cut = dataclasses.replace(plain, handles_cut=3).as_dict()
    said = _seed_verdict(cut)
    assert said.startswith(_seed_verdict(plain.as_dict()))  # the seed's verdict, then how the shapes were cut
    assert "cut open at 3 handles" in said and "the map on the meshes as given was not trusted" in said
    assert "cut open at 1 handle (" in _seed_verdict(dataclasses.replace(plain, handles_cut=1).as_dict())
    assert "cut open" not in _seed_verdict(plain.as_dict())


def test_the_seed_verdict_names_a_landmark_pair_left_out():
    """A verdict with ``left_out`` (kept in JSON records as a list) says which pair went, how far
    the others sent it, and that the feature matches are read from the map."""
    import dataclasses
    import json

    from darcyan.cli import _seed_verdict
    from darcyan.dense.seeds import seed_check

    verdict = dataclasses.replace(seed_check(0, {0: 0.10, 4: 0.09}, 0.04, rival=4), left_out=(3312, 3592, 0.5771))
    about = json.loads(json.dumps(verdict.as_dict()))  # as a record keeps it
    assert about["left_out"] == [3312, 3592, 0.5771]
    said = _seed_verdict(about)
    assert ("the landmark pair 3312 -> 3592 left out (the other pairs sent its source 0.58 sqrt(area) away), "
            "the feature matches read from the map") in said
    assert said.index("left out") < said.index("a start without the feature matches")
    assert "left_out" not in seed_check(0, {0: 0.1}, 0.04).as_dict()
