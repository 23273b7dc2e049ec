"""The front door (darcyan.correspond): the library does what ``darcyan match`` does, and writes
the same bytes."""

import numpy as np
import pytest
from conftest import run_cli

import darcyan
from darcyan import DarcyanError
from darcyan.geometry import synthetic
from darcyan.io.mesh_files import load_mesh

pytestmark = pytest.mark.usefixtures("private_cache")


def command_output(capsys, tmp_path, name, *argv):
    out = tmp_path / name
    code, _, err = run_cli(capsys, "match", *map(str, argv), "-o", str(out))
    assert code == 0, err
    return out.read_bytes()


@pytest.mark.slow
def test_the_same_bytes_as_the_command_sparse_and_dense(small_pose_files, tmp_path, capsys):
    a, b = small_pose_files
    result = darcyan.correspond(str(a), str(b))
    result.to_csv(tmp_path / "api.csv")
    result.to_json(tmp_path / "api.json")
    assert (tmp_path / "api.csv").read_bytes() == command_output(capsys, tmp_path, "cli.csv", a, b)
    assert (tmp_path / "api.json").read_bytes() == command_output(capsys, tmp_path, "cli.json", a, b)
    dense = darcyan.correspond(str(a), str(b), dense=True)
    dense.to_csv(tmp_path / "api-map.csv")
    assert (tmp_path / "api-map.csv").read_bytes() == command_output(capsys, tmp_path, "cli-map.csv", a, b, "--dense")
    assert dense[0].dense.check.trusted and len(dense[0].dense.target) == load_mesh(a).n_vertices


@pytest.mark.slow
def test_several_targets_write_one_map_each_as_the_command_does(small_pose_files, tmp_path, capsys):
    a, b = small_pose_files
    c = tmp_path / "again.off"
    c.write_bytes(b.read_bytes())
    result = darcyan.correspond(a, [b, c], dense=True)
    result.to_csv(tmp_path / "api")
    assert run_cli(capsys, "match", str(a), str(b), str(c), "--dense", "-o", str(tmp_path / "cli"))[0] == 0
    for name in ("figure1.csv", "again.csv"):
        assert (tmp_path / "api" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes()


@pytest.mark.slow
def test_meshes_shapes_and_trimesh_objects_match_like_their_files(small_pose_files):
    import trimesh

    a, b = small_pose_files
    by_file = darcyan.correspond(a, b)[0].matches
    mesh_a, mesh_b = load_mesh(a), load_mesh(b)
    for source, target in ((mesh_a, mesh_b), (darcyan.prepare_shape(mesh_a), darcyan.prepare_shape(mesh_b)),
                           (trimesh.Trimesh(mesh_a.vertices, mesh_a.faces, process=False), str(b))):
        matches = darcyan.correspond(source, target, cache=False)[0].matches
        np.testing.assert_array_equal(matches.source_vertex, by_file.source_vertex)
        np.testing.assert_array_equal(matches.target_vertex, by_file.target_vertex)


@pytest.mark.slow
def test_a_matching_in_doubt_is_verified_as_the_command_does(faust, tmp_path, capsys):
    # tr_reg_016 -> tr_reg_049: two people, the orientation test in doubt (docs: decisions/matching)
    a, b = faust / "tr_reg_016.off", faust / "tr_reg_049.off"
    result = darcyan.correspond(a, b)
    assert result[0].verification is not None and "seed" in result[0].verification
    result.to_csv(tmp_path / "api.csv")
    assert (tmp_path / "api.csv").read_bytes() == command_output(capsys, tmp_path, "cli.csv", a, b)
    dense = darcyan.correspond(a, b, dense=True)
    assert dense[0].verification is None  # the dense map weighs the alternatives itself
    dense.to_csv(tmp_path / "api-map.csv")
    assert (tmp_path / "api-map.csv").read_bytes() == command_output(capsys, tmp_path, "cli-map.csv", a, b, "--dense")


def test_bad_arguments_are_one_clear_error(tmp_path):
    mesh = synthetic.icosphere(2)
    with pytest.raises(DarcyanError, match="verify must be"):
        darcyan.correspond(mesh, mesh, verify="sometimes")
    with pytest.raises(DarcyanError, match="cannot read 'int'"):
        darcyan.correspond(mesh, 3)
    with pytest.raises(DarcyanError, match="no target"):
        darcyan.correspond(mesh, [])
    with pytest.raises(DarcyanError, match="missing.off"):
        darcyan.correspond(tmp_path / "missing.off", mesh)


def test_the_matches_follow_the_seed_of_their_dense_map():
    """A dense map seeded by an alternative contradicts the sparse matching: the matches given
    with the map are that alternative, the sparse matching first among its alternatives."""
    from conftest import tip_correspondence

    from darcyan.api import matches_of_map
    from darcyan.dense.maps import DenseMap, MapCheck
    from darcyan.dense.seeds import seed_check

    tips = synthetic.figure_tips()
    right = tip_correspondence(tips, tips)
    wrong = darcyan.Correspondence(tips, np.roll(tips, 1), np.zeros(len(tips)), None, alternatives=(right,))

    def seeded_by(rank, start="matches"):
        verdict = seed_check(rank, {0: 1.0, rank: 0.5}, 0.04, start)
        return DenseMap(np.zeros(3, np.int64), np.zeros((0, 2), np.int64), check=MapCheck(0.8, 0.01, verdict))

    assert matches_of_map(wrong, seeded_by(0)) is wrong
    assert matches_of_map(wrong, seeded_by(2, "spectral")) is wrong
    chosen = matches_of_map(wrong, seeded_by(1))
    np.testing.assert_array_equal(chosen.target_vertex, tips)
    assert chosen.alternatives[0] is wrong


@pytest.mark.slow
def test_a_verification_reuses_the_source_prepared_beside_the_workers(small_pose_files, monkeypatch):
    """Described in this process beside a worker, the source is not prepared again for the
    verification of its matches (the target, described in the worker, is); the verified
    matches are those of a run that prepares both again (one process)."""
    import darcyan.api

    a, b = small_pose_files
    again = darcyan.correspond(a, b, cache=False, verify=True, jobs=1)[0]
    loaded = []
    real = darcyan.api.load_shape
    monkeypatch.setattr(darcyan.api, "load_shape", lambda path, *args, **kw: loaded.append(path) or real(path, *args, **kw))
    reused = darcyan.correspond(a, b, cache=False, verify=True, jobs=2)[0]
    assert loaded == [b]
    assert reused.verification["seed"] == again.verification["seed"]
    np.testing.assert_array_equal(reused.matches.source_vertex, again.matches.source_vertex)
    np.testing.assert_array_equal(reused.matches.target_vertex, again.matches.target_vertex)


@pytest.mark.slow
def test_the_source_is_kept_only_when_described_here(small_pose_files, tmp_path):
    """describe_keeping_first keeps the first file's shape only when this process prepared it:
    not when its description comes from the cache, nor when every file goes to a worker
    (more files than jobs), nor when the files are described in turn (one job)."""
    from darcyan.io.cache import ShapeCache
    from darcyan.method.pipeline import describe_keeping_first

    a, b = small_pose_files
    c = tmp_path / "third.off"
    c.write_bytes(b.read_bytes())
    config = darcyan.DarcyanConfig()
    descriptions, kept = describe_keeping_first([a, b], config, jobs=2)
    assert kept is not None and kept.mesh.n_vertices > 0 and len(descriptions) == 2
    assert describe_keeping_first([a, b, c], config, jobs=2)[1] is None  # three files, two jobs: all in workers
    assert describe_keeping_first([a, b], config, jobs=1)[1] is None
    cache = ShapeCache(tmp_path / "cache")
    describe_keeping_first([a], config, cache=cache)
    assert describe_keeping_first([a, b, c], config, cache=cache, jobs=2)[1] is None  # a from the cache
