"""Geometry of triangle meshes: the mesh type, checks and repair, operators, geodesics, spectra."""
