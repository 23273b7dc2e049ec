"""darcyan: correspondences between non-rigid 3D shapes with the Darcyan curvature descriptor.

Implements Sboui et al., "A Novel Darcyan Curvature-Based Descriptor for 3D Non-rigid Shape
Matching": feature points at AGD maxima, a Darcyan coordinate system (geodesic level curves x
radial geodesics) around each, the mean principal curvatures per level curve as descriptor, and
L2 nearest-neighbour matching.

    >>> import darcyan
    >>> shape_1 = darcyan.describe_shape("cat0.off")          # doctest: +SKIP
    >>> shape_2 = darcyan.describe_shape("cat1.off")          # doctest: +SKIP
    >>> matches = darcyan.match_shapes(shape_1, shape_2)      # doctest: +SKIP
"""

from ._version import __version__  # noqa: F401 (darcyan.__version__)
from .api import Correspondences, PairResult, correspond
from .config import DarcyanConfig
from .errors import ConfigError, DarcyanError, DependencyError, MeshError
from .geometry.curvature import Curvatures, principal_curvatures
from .geometry.geodesics import GeodesicSolver
from .geometry.mesh import Mesh, MeshWarning, normalize_mesh
from .geometry.repair import prepare_mesh
from .geometry.shape import Shape, prepare_shape
from .io.cache import ShapeCache
from .io.mesh_files import load_mesh, save_mesh
from .method.descriptors import curvature_descriptor, curvature_descriptors
from .method.features import AGD, FeaturePoints, average_geodesic_distance, extremities
from .method.grid import DarcyanGrid, darcyan_grid, darcyan_grids
from .method.matching import Matches, descriptor_distances, match_descriptors
from .method.pipeline import (
                              Correspondence,
                              ShapeAnalysis,
                              ShapeDescription,
                              analyze_mesh,
                              analyze_shape,
                              describe_shape,
                              load_shape,
                              match_files,
                              match_shapes,
)
from .parallel import get_threads, set_threads

__all__ = [
    "AGD", "ConfigError", "Correspondence", "Correspondences", "PairResult", "correspond", "Curvatures",
    "DarcyanConfig", "DarcyanError", "DarcyanGrid", "DependencyError", "FeaturePoints", "GeodesicSolver",
    "Matches", "Mesh", "MeshError", "MeshWarning", "Shape", "ShapeAnalysis", "ShapeCache", "ShapeDescription",
    "analyze_mesh", "analyze_shape", "average_geodesic_distance", "curvature_descriptor",
    "curvature_descriptors", "darcyan_grid", "darcyan_grids", "describe_shape", "descriptor_distances",
    "extremities", "load_mesh", "load_shape", "match_descriptors", "match_files", "match_shapes",
    "normalize_mesh", "get_threads", "prepare_mesh", "prepare_shape", "principal_curvatures", "save_mesh",
    "set_threads",
]
