"""The settings of a ``darcyan bench`` run (:class:`BenchSettings`): what a resumed run must share."""

from __future__ import annotations

from dataclasses import dataclass, field

from ..config import DarcyanConfig
from ..dense import pyfm
from ..eval.dense_scores import DENSE_SAMPLE, DENSE_SEED
from ..eval.metrics import DEFAULT_THRESHOLD
from ..geometry import spectral as lbo
from . import DENSE_METHODS

MIRROR_MAX_RESIDUAL = 0.005  # a pose whose best reflection leaves more (sqrt(area) units) is not symmetric


@dataclass(frozen=True)
class BenchSettings:
    """What a run computes; results of runs with other settings are never mixed."""

    methods: tuple
    threshold: float = DEFAULT_THRESHOLD
    config: DarcyanConfig = field(default_factory=DarcyanConfig)
    laplacian: str = "cotangent"
    repair: bool = False
    dense: bool = False
    dense_samples: int = DENSE_SAMPLE
    dense_seed: int = DENSE_SEED

    @property
    def dense_methods(self) -> tuple:
        """The dense maps of a pair: darcyan's, and pyFM's own when ``pyfm`` is a method."""
        return tuple(m for m in DENSE_METHODS if m == "darcyan" or m in self.methods) if self.dense else ()

    def dense_settings(self) -> dict | None:
        """What the dense results depend on (``None`` without ``dense``)."""
        if not self.dense:
            return None
        import dataclasses

        return {"samples": self.dense_samples, "seed": self.dense_seed,
                "config": dataclasses.asdict(self.config.dense_for()),
                "pyfm": dataclasses.asdict(pyfm.DENSE_PIPELINE)}

    def as_dict(self) -> dict:
        import dataclasses

        from ..eval import baselines

        return {"methods": list(self.methods), "threshold": self.threshold, "config": self.config.as_dict(),
                "laplacian": self.laplacian, "repair": self.repair, "dense": self.dense_settings(),
                "baselines": {"spectrum_size": lbo.SPECTRUM_SIZE,
                              "signature_samples": baselines.SIGNATURE_SAMPLES,
                              "pyfm": dataclasses.asdict(pyfm.README_PIPELINE)}}

    def comparable(self) -> dict:
        """The settings that must match for resumed results to be reused (:func:`comparable`
        of :meth:`as_dict`)."""
        return comparable(self.as_dict())


def comparable(settings: dict) -> dict:
    """Of a run's settings as :meth:`BenchSettings.as_dict` gives them (or ``run.json`` keeps
    them), those that must match for resumed results to be reused: not the method list, and not
    the dense settings, compared apart when both runs have them."""
    return {key: value for key, value in settings.items() if key not in ("methods", "dense")}
