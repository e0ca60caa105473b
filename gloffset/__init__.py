"""gloffset: the region within a distance of curves and polygons on the sphere.

Exact vector offsets made of small-circle arcs (:mod:`gloffset.vector`), a fast inside
test (:mod:`gloffset.index`), rasters over grids (:mod:`gloffset.grids`,
:mod:`gloffset.raster`, rendered on the GPU by :mod:`gloffset.gl`) and a float64
reference for distances and membership (:mod:`gloffset.reference`); vector files through
:mod:`gloffset.io.vectorfile` and metric buffers of GeoPandas data (:func:`buffer`,
:mod:`gloffset.geoseries`). Distances are angles inside; metres appear only through the
``radius`` keyword, or, with ``ellipsoid="WGS84"`` on :func:`distance`, :func:`contains`,
:func:`render` and :func:`offset`, as geodesic lengths on the ellipsoid
(:mod:`gloffset.ellipsoidal`, :mod:`gloffset.geodesic_offset`, :mod:`gloffset.ellipsoid`).
The layers are described in ``ARCHITECTURE.md``; everything public is re-exported here.
"""

from __future__ import annotations

from . import errors, grids, tiles
from ._version import __version__
from .ellipsoid import Ellipsoid
from .ellipsoidal import contains, distance
from .errors import *  # noqa: F403  (every exception class, listed in errors.__all__)
from .geodesic_offset import GeodesicOffset, offset
from .geoseries import buffer
from .index.tree import Index
from .io import geojson as _geojson
from .mvt import vector_tile
from .raster.field import DistanceField, distance_field
from .raster.many import mask_bands, render_many
from .raster.rasterized import raster_offset, rasterize
from .raster.render import render
from .shape import Shape, read
from .units import EARTH_RADIUS, parse_distance
from .vector import arcrings as _arcrings
from .vector.multires import Decomposition, decompose
from .vector.offset import Offset
from .vector.resolved import ResolvedOffset

# Offsets are written by io/, which vector/ does not import: the convenience methods
# Offset.to_geojson and ResolvedOffset.to_geojson call the writers of gloffset.io.geojson.
_arcrings.ArcRings.writer = _geojson

__all__ = [
    "EARTH_RADIUS",
    "Index",
    "Decomposition",
    "DistanceField",
    "Ellipsoid",
    "GeodesicOffset",
    "Offset",
    "ResolvedOffset",
    "Shape",
    "__version__",
    "buffer",
    "contains",
    "decompose",
    "distance",
    "distance_field",
    "mask_bands",
    "offset",
    "parse_distance",
    "raster_offset",
    "rasterize",
    "read",
    "render",
    "render_many",
    "grids",
    "tiles",
    "vector_tile",
    *errors.__all__,
]
