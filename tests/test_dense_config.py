"""The settings of a dense map (:class:`darcyan.dense.config.DenseConfig`): bad values are
ConfigErrors."""

import pytest

from darcyan.dense.config import DenseConfig
from darcyan.errors import ConfigError


def test_dense_config_rejects_a_bad_commutativity():
    for bad in (-1.0, float("nan"), True, "3"):
        with pytest.raises(ConfigError, match="dense: commutativity must be non-negative"):
            DenseConfig(commutativity=bad)


def test_dense_config_rejects_a_bad_margin():
    for bad in (dict(basis_margin=-1), dict(margin_from=2.5), dict(basis_margin="10"), dict(verify_proxy_vertices=-1),
                dict(verify_proxy_vertices=1.5)):
        with pytest.raises(ConfigError, match=f"dense: {next(iter(bad))} must be a non-negative integer"):
            DenseConfig(**bad)


def test_dense_config_rejects_bad_seed_settings():
    with pytest.raises(ConfigError, match="candidates"):
        DenseConfig(candidates=0)
    with pytest.raises(ConfigError, match="signature_lengths"):
        DenseConfig(signature_lengths=(0.1, -1))
    with pytest.raises(ConfigError, match="trust_orientation"):
        DenseConfig(trust_orientation=2)
    with pytest.raises(ConfigError, match="signature_lengths"):
        DenseConfig(signature_lengths=(True,))
    with pytest.raises(ConfigError, match="seed_margin"):
        DenseConfig(seed_margin=1.0)
    assert DenseConfig(signature_lengths=[0.1]).signature_lengths == (0.1,)


def test_bad_sampling_is_a_config_error():
    with pytest.raises(ConfigError, match="sampling"):
        DenseConfig(sampling="poisson")


def test_the_rivals_switches_are_true_or_false():
    for name in ("start_in_doubt", "rival_by_checks", "rival_sure_matching", "rival_best_scored"):
        for bad in ("false", 0, None):
            with pytest.raises(ConfigError, match=f"{name} must be true or false"):
                DenseConfig(**{name: bad})
        assert getattr(DenseConfig(**{name: False}), name) is False


def test_rival_agreement_is_a_share_and_its_radius_non_negative():
    for bad in (-0.1, 1.5, "half", True):
        with pytest.raises(ConfigError, match="rival_agreement must be a share"):
            DenseConfig(rival_agreement=bad)
    with pytest.raises(ConfigError, match="rival_agreement_radius must be non-negative"):
        DenseConfig(rival_agreement_radius=-0.01)
    assert DenseConfig(rival_agreement=0.0, rival_agreement_radius=0.0).rival_agreement == 0.0


def test_dense_config_rejects_a_bad_alignment_stretch():
    for bad in (-0.1, float("inf"), True, "0.2"):
        with pytest.raises(ConfigError, match="dense: alignment_stretch must be non-negative"):
            DenseConfig(alignment_stretch=bad)
    assert DenseConfig(alignment_stretch=0.15).alignment_stretch == 0.15
