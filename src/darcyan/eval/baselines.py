"""Baseline descriptors for the benchmark, evaluated at darcyan's own feature points.

- ``hks``: the Heat Kernel Signature (Sun, Ovsjanikov and Guibas 2009),
  ``HKS(x, t) = sum_i exp(-lambda_i t) phi_i(x)^2``, scaled by the heat trace
  ``sum_i exp(-lambda_i t)`` at each time, at times log-spaced over
  ``[4 ln 10 / lambda_max, 4 ln 10 / lambda_1]``.
- ``wks``: the Wave Kernel Signature (Aubry, Schlickewei and Cremers 2011),
  ``WKS(x, e) = sum_i phi_i(x)^2 exp(-(e - log lambda_i)^2 / 2 sigma^2)`` normalized by
  ``sum_i exp(-(e - log lambda_i)^2 / 2 sigma^2)``, energies ``e`` evenly spaced in log-eigenvalue.

Both come from the Laplace-Beltrami eigenbasis of the prepared mesh scaled to area 1
(:func:`laplace_beltrami_spectrum`: cotangent stiffness with a lumped mixed-Voronoi mass, or
``robust-laplacian``; generalized eigenproblem solved by ``scipy.sparse.linalg.eigsh`` in
shift-invert mode), skipping the constant eigenfunction. They are matched by L2 exactly like
darcyan's descriptor, so the benchmark compares descriptors, not set-ups.

- ``pyfm``: the dense functional-map pipeline of PyPI's ``pyfmaps`` (optional extra ``[pyfm]``):
  WKS descriptors, a functional map fitted with Laplacian and descriptor commutativity, refined
  by ZoomOut, converted to a vertex-to-vertex map that is read at darcyan's source feature points.
"""

from __future__ import annotations

import numpy as np

from ..dense import pyfm
from ..errors import ConfigError
from ..geometry.mesh import Mesh
from ..geometry.spectral import Spectrum

SIGNATURE_SAMPLES = 100  # times (HKS) or energies (WKS) per signature
HKS_DECAY = 4.0 * np.log(10.0)  # t_min/t_max: exp(-lambda t) drops to 1e-4 at lambda_max/lambda_1
WKS_VARIANCE = 7.0  # sigma = WKS_VARIANCE * energy step (Aubry et al.)
WKS_MARGIN = 2.0  # energies start and stop this many sigmas inside the log-spectrum
SPECTRAL_METHODS = ("hks", "wks")




def _nonconstant(spectrum: Spectrum) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues and eigenvectors without the constant pair (and any other ~0 ones)."""
    keep = spectrum.values > spectrum.values[-1] * 1e-9
    keep[0] = False
    return spectrum.values[keep], spectrum.vectors[:, keep]


def heat_kernel_signature(spectrum: Spectrum, vertices: np.ndarray, samples: int = SIGNATURE_SAMPLES) -> np.ndarray:
    """``(len(vertices), samples)`` scaled HKS at ``vertices`` (indices of the spectrum's mesh)."""
    values, vectors = _nonconstant(spectrum)
    times = np.geomspace(HKS_DECAY / values[-1], HKS_DECAY / values[0], samples)
    decay = np.exp(-np.outer(values, times))  # (k, samples)
    phi2 = vectors[np.asarray(vertices, dtype=np.int64)] ** 2  # (v, k)
    return (phi2 @ decay) / decay.sum(axis=0)[None, :]


def wave_kernel_signature(spectrum: Spectrum, vertices: np.ndarray, samples: int = SIGNATURE_SAMPLES) -> np.ndarray:
    """``(len(vertices), samples)`` WKS at ``vertices`` (indices of the spectrum's mesh)."""
    values, vectors = _nonconstant(spectrum)
    log_values = np.log(values)
    step = (log_values[-1] - log_values[0]) / samples
    sigma = WKS_VARIANCE * step
    energies = np.linspace(log_values[0] + WKS_MARGIN * sigma, log_values[-1] - WKS_MARGIN * sigma, samples)
    weights = np.exp(-((energies[None, :] - log_values[:, None]) ** 2) / (2.0 * sigma**2))  # (k, samples)
    phi2 = vectors[np.asarray(vertices, dtype=np.int64)] ** 2
    return (phi2 @ weights) / weights.sum(axis=0)[None, :]


def spectral_descriptors(method: str, spectrum: Spectrum, vertices: np.ndarray) -> np.ndarray:
    """``hks`` or ``wks`` descriptors at ``vertices``."""
    if method == "hks":
        return heat_kernel_signature(spectrum, vertices)
    if method == "wks":
        return wave_kernel_signature(spectrum, vertices)
    raise ConfigError(f"spectral descriptor must be one of {SPECTRAL_METHODS}, got {method!r}")


# ---------------------------------------------------------------------------------------------
# pyfmaps


def pyfm_point_map(source: Mesh, target: Mesh, source_spectrum: tuple | None = None,
                   target_spectrum: tuple | None = None) -> np.ndarray:
    """``(n_source,)`` the target vertex of every source vertex by pyfmaps' pipeline at the
    settings of its README (:data:`darcyan.dense.pyfm.README_PIPELINE`); spectra from
    :func:`darcyan.dense.pyfm.pyfm_spectrum` save computing them again."""
    return pyfm.pyfm_point_map(source, target, pyfm.README_PIPELINE, spectra=(source_spectrum, target_spectrum))
