"""The configuration: every setting typed and checked, cache keys derived from the fields."""

from __future__ import annotations

import dataclasses
import json

import pytest

from darcyan.config import (
    DENSE,
    DESCRIBE,
    LANDMARK_MODES,
    LAPLACIANS,
    MATCH,
    MATCHING_MODES,
    METHODS,
    PREPARE,
    SAMPLINGS,
    SECTIONS,
    SEED_STATISTICS,
    DarcyanConfig,
    MirrorTest,
    _stage_of,
    _staged_fields,
    field_docs,
)
from darcyan.errors import ConfigError


def _other_value(value):
    """A different value of the same type, inside every field's valid range (checked by the
    config itself when the changed copy is built)."""
    if isinstance(value, str):
        return "nearest" if value != "nearest" else "consistent"
    if isinstance(value, bool):
        return not value
    if isinstance(value, int):
        return value + 1
    if isinstance(value, float):
        return value * 1.1 + (0.01 if value >= 0 else -0.01)
    if isinstance(value, tuple):
        return tuple(v * 1.1 for v in value)
    if value is None:  # an optional count left to a default (e.g. DenseConfig.signature_smoothing)
        return 2
    raise AssertionError(f"no other value for {value!r}")


# The choices of each setting that is a name: another one of them is its other value.
CHOICES = {"matching": MATCHING_MODES, "method": METHODS, "landmarks": LANDMARK_MODES, "sampling": SAMPLINGS,
           "seed_statistic": SEED_STATISTICS, "basis_laplacian": LAPLACIANS}


def _changed(config: DarcyanConfig, dotted: str) -> DarcyanConfig:
    leaf = dotted.split(".")[-1]

    def other(value):
        if isinstance(value, str):
            return next(choice for choice in CHOICES[leaf] if choice != value)
        return _other_value(value)

    if "." not in dotted:
        return config.replace(**{dotted: other(getattr(config, dotted))})
    section, leaf = dotted.split(".")
    owner = getattr(config, section)
    return config.replace(**{section: dataclasses.replace(owner, **{leaf: other(getattr(owner, leaf))})})


LEAVES = [name for name, _ in _staged_fields(DarcyanConfig())]


def test_every_setting_is_found():
    """The walk over the fields reaches the sections: the keys below cannot pass vacuously."""
    assert len(LEAVES) > 40
    assert {"radius", "matching", "mirror.handedness_weight", "heat.vertices", "denoising.block",
            "dense.seed_statistic"} <= set(LEAVES)
    assert {_stage_of(DarcyanConfig(), name) for name in LEAVES} == {PREPARE, DESCRIBE, MATCH, DENSE}


def test_the_dense_settings_are_a_section_set_by_a_config_file():
    changed = DarcyanConfig().updated({"dense": {"ensemble": 3}}, "settings.json")
    assert changed.dense.ensemble == 3 and changed.describe_fingerprint() == DarcyanConfig().describe_fingerprint()
    assert changed.fingerprint(DENSE) != DarcyanConfig().fingerprint(DENSE)
    with pytest.raises(ConfigError, match="settings.json: unknown setting dense.ensembles"):
        DarcyanConfig().updated({"dense": {"ensembles": 3}}, "settings.json")
    with pytest.raises(ConfigError, match="ensemble"):
        DarcyanConfig().updated({"dense": {"ensemble": 0}})


@pytest.mark.parametrize("section", [DarcyanConfig, *SECTIONS.values()])
def test_every_field_is_documented_once_in_its_class(section):
    """The command-line help and the settings reference read these: no field without its text."""
    documented = field_docs(section)
    for field in dataclasses.fields(section):
        if field.name not in SECTIONS or section is not DarcyanConfig:
            assert documented.get(field.name), f"{section.__name__}.{field.name} has no documentation"


@pytest.mark.parametrize("name", LEAVES)
def test_changing_a_field_changes_the_keys_of_its_stage(name):
    base = DarcyanConfig()
    changed = _changed(base, name)
    stage = _stage_of(base, name)
    assert changed.fingerprint() != base.fingerprint()
    # preparing feeds describing: a prepare setting changes both keys, a describe setting the
    # description's only, a match setting neither (a cached description stays valid)
    assert (changed.prepare_fingerprint() != base.prepare_fingerprint()) == (stage == PREPARE)
    assert (changed.describe_fingerprint() != base.describe_fingerprint()) == (stage in (PREPARE, DESCRIBE))


def test_the_config_survives_json_and_the_paper_preset_differs():
    for config in (DarcyanConfig(), DarcyanConfig.paper(), DarcyanConfig(mirror=MirrorTest(samples=100))):
        again = DarcyanConfig(**json.loads(json.dumps(config.as_dict())))
        assert again == config and again.fingerprint() == config.fingerprint()
    assert DarcyanConfig.paper().describe_fingerprint() != DarcyanConfig().describe_fingerprint()


@pytest.mark.parametrize("section, field, value", [
    ("mirror", "samples", 0), ("mirror", "min_sine", 1.5), ("mirror", "verify_sparse_below", -0.5),
    ("heat", "tolerance", -1.0),
    ("denoising", "taubin_mu", 0.2), ("margins", "trace", 0.5), ("consistency", "beam_width", 0)])
def test_a_section_value_out_of_range_names_it(section, field, value):
    kind = SECTIONS[section]
    with pytest.raises(ConfigError, match=f"{kind.__name__}.{field}"):
        kind(**{field: value})


def test_a_section_of_the_wrong_type_is_refused():
    with pytest.raises(ConfigError, match="mirror must be a MirrorTest"):
        DarcyanConfig(mirror=3)


def test_settings_from_a_json_file_reach_every_section(tmp_path, capsys):
    from darcyan.cli import _config, build_parser, main

    path = tmp_path / "settings.json"
    path.write_text(json.dumps({"radius": 0.1, "mirror": {"samples": 400}, "heat": {"vertices": 3000}}))
    config = _config(build_parser().parse_args(["features", "x.off", "--config", str(path), "--levels", "5"]))
    assert (config.radius, config.levels, config.mirror.samples, config.heat.vertices) == (0.1, 5, 400, 3000)
    assert config.mirror.neighbours == MirrorTest().neighbours  # the rest of the section kept
    path.write_text(json.dumps({"mirror": {"sample": 400}}))
    assert main(["features", "x.off", "--config", str(path)]) == 2
    assert "unknown setting mirror.sample" in capsys.readouterr().err
    path.write_text(json.dumps({"mirror": {"samples": "many"}}))
    assert main(["features", "x.off", "--config", str(path)]) == 2
    assert capsys.readouterr().err.startswith(f"darcyan: error: {path}: config: MirrorTest.samples")


@pytest.mark.parametrize("changes", [{"mirror": {"signature_lengths": 5}}, {"mirror": {"signature_lengths": ["a"]}},
                                     {"consistency": {"beam_width": True}}, {"levels": True}])
def test_values_of_the_wrong_kind_are_one_config_error(changes):
    with pytest.raises(ConfigError):
        DarcyanConfig().updated(changes)
