"""darcyan bench reports groups of pairs named by a third column of --pairs."""

import json

import pytest

from darcyan.bench.datasets import discover_dataset, read_pairs
from darcyan.bench.runner import run_bench
from darcyan.errors import DarcyanError
from darcyan.geometry import synthetic
from darcyan.io.mesh_files import save_mesh


@pytest.fixture(scope="module")
def figures(tmp_path_factory):
    """The built-in figure in three poses (one vertex numbering: identity ground truth)."""
    folder = tmp_path_factory.mktemp("figures")
    for pose in (0, 1, 2):
        save_mesh(synthetic.figure(pose, 4), folder / f"figure{pose}.off")
    return folder


def test_pairs_file_third_column_names_groups(figures, tmp_path):
    pairs = tmp_path / "pairs.txt"
    pairs.write_text("figure0\tfigure1\tnear\nfigure0\tfigure2\tfar away\nfigure1\tfigure2\n")
    groups = {}
    found = read_pairs(pairs, discover_dataset(figures), groups)
    assert found == [("figure0", "figure1"), ("figure0", "figure2"), ("figure1", "figure2")]
    assert groups == {("figure0", "figure1"): "near", ("figure0", "figure2"): "far away"}
    pairs.write_text("figure0\tfigure1\tnear\textra\n")
    with pytest.raises(DarcyanError, match="line 1"):
        read_pairs(pairs, discover_dataset(figures), {})


@pytest.mark.slow
def test_results_and_report_per_group(figures, tmp_path):
    pairs = tmp_path / "pairs.txt"
    pairs.write_text("figure0\tfigure1\tnear\nfigure0\tfigure2\tfar\nfigure1\tfigure2\tfar\n")
    result = run_bench(figures, tmp_path / "out", pairs_file=pairs, cache_dir=tmp_path / "cache", progress=False,
                       dense=True, dense_samples=200)
    results = json.loads((tmp_path / "out" / "results.json").read_text())
    sparse = results["methods"]["darcyan"]
    assert sorted(sparse["groups"]) == ["far", "near"]
    assert sparse["groups"]["near"]["pairs"] == 1 and sparse["groups"]["far"]["pairs"] == 2
    # the groups partition the pairs: their matches add up to the whole run's
    assert sum(g["matches"] for g in sparse["groups"].values()) == sparse["overall"]["matches"]
    for g in sparse["groups"].values():
        assert 0 <= g["mean_error"] < 0.25 and len(g["curve"]) == len(results["taus"])
    dense = results["dense"]["darcyan"]["groups"]
    assert dense["far"]["samples"] == 2 * dense["near"]["samples"] == 400
    # each dense map says which matching seeded it and how right that one was
    records = results["dense"]["darcyan"]["pairs"]
    for r in records:
        assert 0 <= r["seed_correct"] <= r["seed_matches"] <= r["seed_features"] and "trusted" in r["check"]
    if all(r["check"]["seed"] == 0 for r in records):  # seeded by the sparse matches: the same rate
        for name, g in dense.items():
            assert g["seed_rate"] == pytest.approx(sparse["groups"][name]["rate"])
    report = (tmp_path / "out" / "report.md").read_text()
    assert "## Per group" in report and "| near | darcyan | 1 |" in report
    seconds = [r["seconds"] for r in results["pairs"] if r["method"] == "darcyan"]
    assert f"| {sum(seconds) / len(seconds):.2f} |" in report  # a pair's mean time, not the class's sum
    assert (tmp_path / "out" / "group_curves.png").stat().st_size > 10_000
    assert result.computed == 6  # three sparse and three dense records


def test_faust_held_out_pairs_are_outside_the_test_list(faust):
    """benchmarks/faust5k_heldout_pairs.txt: 40 pairs of existing shapes, none in the published
    test list in either order, their group the persons' (tr_reg_0XY: person X)."""
    from pathlib import Path

    listed = set()
    for line in (faust / "test_pairs.txt").read_text().splitlines():
        if line.strip():
            a, b = line.split()[:2]
            listed |= {(a, b), (b, a)}
    text = (Path(__file__).resolve().parents[1] / "benchmarks" / "faust5k_heldout_pairs.txt").read_text()
    rows = [line.split("\t") for line in text.splitlines() if line.strip() and not line.startswith("#")]
    assert len(rows) == 40 and len({(a, b) for a, b, _ in rows}) == 40
    for source, target, group in rows:
        assert (faust / f"{source}.off").is_file() and (faust / f"{target}.off").is_file()
        assert source != target and (source, target) not in listed
        assert group == ("same person" if source[-2] == target[-2] else "two people")
