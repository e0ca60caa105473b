"""Fast inside/outside and offset-membership tests (paper Sec. 4.3, Eq. 5-9).

A point ``p`` lies in the offset region of a shape at signed distance ``d`` when

* ``d > 0``: it is inside a polygon, or within ``d`` of a curve (Eq. 6, 8);
* ``d < 0``: it is inside a polygon and farther than ``|d|`` from its boundary;
* ``d = 0``: it is inside a polygon.

An :class:`Index` answers this for millions of points. It is built once per shape
and distance from three pieces:

1. **Bins** (:mod:`gloffset.index.bins`): a lon/lat quadtree refined only where the
   answer varies; a point in a decided cell costs a few table look-ups;
2. **the multiresolution arc tree** (:mod:`gloffset.vector.multires`): the candidate
   arcs of the frontier cells, at a decomposition level ``K``;
3. **exact tests in frontier cells**: the crossing parity of the short arc from the
   point to its cell's anchor, with simplified arcs reconstructed only where the point
   lies in their error region (Eq. 9).

A point and the anchor of its cell are always judged with the same arithmetic; the
accuracy contract is that of :func:`contains_on_sphere`. The derivation in full:
``docs/design.md``, *Module notes*.
"""

from __future__ import annotations

import math

import numpy as np

from ..edges import contains_xyz
from ..geometry.caps import cap_within
from ..geometry.sphere import lonlat_to_xyz
from ..shape import Shape, read
from ..units import EARTH_RADIUS, check_lonlat, offset_angle
from .tree import DEFAULT_DEPTH, Index

__all__ = ["contains_on_sphere", "contains_angle", "depth_for"]

#: Indexes kept on a shape (by distance and level).
CACHE_SIZE = 4


def depth_for(n_points: int) -> int:
    """Bin depth worth building for a query of ``n_points`` points.

    Building costs about the number of frontier cells, which doubles with each
    level; answering costs about the number of points that fall in frontier cells,
    which halves. The balance moves one level per factor 4 in the number of points:
    :data:`DEFAULT_DEPTH` at a million points, 10 at ten thousand, 3 for one point.
    """
    depth = DEFAULT_DEPTH + 0.5 * math.log2(max(n_points, 1) / 1e6)
    return int(max(3, min(DEFAULT_DEPTH, round(depth))))


def _index(shape, d: float, level, n_points: int) -> Index:
    """Return the cached index of ``shape`` for angle ``d`` and ``level``.

    Deep enough for a query of ``n_points`` points (built, or rebuilt deeper, when
    needed).
    """
    want = depth_for(n_points)
    return shape.derived.contains_indexes.once(
        (d, level),
        lambda: Index.at_angle(shape, d, level=level, depth=want),
        fresh=lambda ix: ix.requested_depth >= want,
        keep=CACHE_SIZE,
    )


def contains_on_sphere(
    shape, lon, lat, *, distance: float = 0.0, radius: float = EARTH_RADIUS, level=None
) -> np.ndarray:
    """Whether points lie in the offset region of the shape (fast and exact).

    Parameters
    ----------
    shape : Shape or anything :func:`gloffset.read` accepts
        Pass a :class:`Shape` to reuse its index between calls.
    lon, lat : array_like
        Query points in degrees (broadcast together).
    distance : float
        Offset distance in the units of ``radius``. ``0`` tests the polygons
        themselves; ``> 0`` adds everything within that distance of the curves;
        ``< 0`` keeps points of the polygons farther than ``|distance|`` from their
        boundary.
    radius : float
        Sphere radius (default :data:`gloffset.EARTH_RADIUS`, metres).
    level : int, optional
        Decomposition level of the candidate arcs (see :class:`Index`); ``None``
        chooses.

    Returns
    -------
    numpy.ndarray of bool, the broadcast shape of ``lon`` and ``lat``.

    Notes
    -----
    Accuracy: the same answer as the brute-force reference
    (:func:`gloffset.reference.contains_lonlat`) for every point farther than 1e-13 rad
    from the boundary and whose distance differs from ``|distance|`` by more than
    1e-13 rad. Polygons are united; lines and points have no inside. Where region
    components overlap (:meth:`Shape.overlapping_components`, e.g. overlapping
    features), points within the bounding caps of two overlapping components are
    answered by the exact test against every ring edge
    (:func:`gloffset.edges.contains_xyz`), which unites them; elsewhere the index's
    crossing count is the union already.

    The index (:class:`Index`) is built on the first call for a shape, distance and
    level, and kept on the shape (the last :data:`CACHE_SIZE` of them); its bins are
    as deep as the number of points of the call makes worthwhile (:func:`depth_for`),
    and rebuilt deeper when a later call brings many more points.

    Examples
    --------
    >>> import gloffset
    >>> ring = [[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]]
    >>> sq = gloffset.read({"type": "Polygon", "coordinates": [ring]})
    >>> gloffset.contains(sq, [5.0, 10.5], [5.0, 5.0]).tolist()
    [True, False]
    >>> gloffset.contains(sq, [5.0, 10.5], [5.0, 5.0], distance=100e3).tolist()
    [True, True]
    """
    shape = read(shape)
    return contains_angle(shape, lon, lat, offset_angle(shape, distance, radius), level)


def contains_angle(shape: Shape, lon, lat, d: float, level=None) -> np.ndarray:
    """Return :func:`contains_on_sphere` of a read ``shape`` at the angle ``d`` (radians).

    The angle is checked by the caller (:func:`gloffset.units.offset_angle`).
    """
    lon, lat, shp = check_lonlat(lon, lat)
    out = _index(shape, d, level, len(lon))._query(lon, lat)
    pairs = shape.overlapping_components()
    if len(pairs):
        # the index counts crossings over all rings at once (even-odd), which is the
        # union except where components overlap: points that may lie in two
        # overlapping components (within both their bounding caps) take the exact test
        # of every ring edge (gloffset.edges.contains_xyz), which unites them
        p = lonlat_to_xyz(lon, lat)
        centres, radii = shape.component_caps()
        near = cap_within(p @ centres.T, radii[None, :])
        risky = np.any(near[:, pairs[:, 0]] & near[:, pairs[:, 1]], axis=1)
        if risky.any():
            out[risky] = contains_xyz(shape, p[risky], d)
    return out.reshape(shp)
