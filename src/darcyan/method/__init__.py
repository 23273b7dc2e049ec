"""The Darcyan method: curvature, feature points, grids, descriptors, matching, mirror test, pipeline."""
