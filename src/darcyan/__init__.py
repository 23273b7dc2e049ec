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

from .cache import ShapeCache
from .config import DarcyanConfig
from .curvature import Curvatures, principal_curvatures
from .descriptors import curvature_descriptor, curvature_descriptors
from .errors import ConfigError, DarcyanError, DependencyError, MeshError
from .features import AGD, FeaturePoints, average_geodesic_distance, extremities
from .geodesics import GeodesicSolver
from .grid import DarcyanGrid, darcyan_grid, darcyan_grids
from .matching import Matches, descriptor_distances, match_descriptors
from .mesh import Mesh, MeshWarning, load_mesh, normalize_mesh, prepare_mesh, save_mesh
from .pipeline import (Correspondence, ShapeDescription, analyze_mesh, describe_shape, match_files,
                       match_shapes)

__version__ = "0.1.0"

__all__ = [
    "AGD", "ConfigError", "Correspondence", "Curvatures", "DarcyanConfig", "DarcyanError", "DarcyanGrid",
    "DependencyError", "FeaturePoints", "GeodesicSolver", "Matches", "Mesh", "MeshError", "MeshWarning",
    "ShapeCache", "ShapeDescription", "analyze_mesh", "average_geodesic_distance", "curvature_descriptor",
    "curvature_descriptors", "darcyan_grid", "darcyan_grids", "describe_shape", "descriptor_distances",
    "extremities", "load_mesh", "match_descriptors", "match_files", "match_shapes", "normalize_mesh",
    "prepare_mesh", "principal_curvatures", "save_mesh",
]
