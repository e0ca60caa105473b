"""One Mapbox Vector Tile (MVT 2.1) of the offset region: :func:`vector_tile`.

The tile's polygons come from the region's exact boundary near the tile
(:mod:`gloffset.mvt.boundary`), cut and rounded by :mod:`gloffset.mvt.geometry`, and are
encoded by ``mapbox-vector-tile`` (the ``mvt`` extra).
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidGridError, OptionError
from ..grids.mercator import check_zoom
from ..shape import read
from ..units import EARTH_RADIUS, VECTOR_LIMIT, check_radius, distance_properties, offset_angle
from .boundary import LocalBoundary, ResolvedBoundary
from .densify import densify
from .geometry import TileFrame, clip_rings, to_polygons

__all__ = [
    "vector_tile",
    "check_mvt_options",
    "tile_geometry",
    "boundary_for",
    "encode",
    "DEFAULT_LAYER",
]

#: The layer's name when the input has none.
DEFAULT_LAYER = "offset"

#: A tile at a distance not kept on the shape resolves only the edges near it
#: (:class:`~gloffset.mvt.boundary.LocalBoundary`) when they are at most this share of the
#: input's edges; past it, the whole offset once (kept for the next tiles).
LOCAL_SHARE = 0.25


def check_mvt_options(extent, buffer) -> tuple[int, int]:
    """Return ``(extent, buffer)`` as ints, or raise :class:`~gloffset.errors.OptionError`.

    The extent must be a power of two from 256 to 65536, the buffer from 0 to the extent.
    """
    if isinstance(extent, bool) or not isinstance(extent, (int, np.integer)):
        raise OptionError(f"extent must be an integer power of two, got {extent!r}")
    e = int(extent)
    if e < 256 or e > 65536 or e & (e - 1):
        raise OptionError(f"extent must be a power of two from 256 to 65536, got {e}")
    if isinstance(buffer, bool) or not isinstance(buffer, (int, np.integer)):
        raise OptionError(f"buffer must be an integer number of tile units, got {buffer!r}")
    b = int(buffer)
    if b < 0 or b > e:
        raise OptionError(f"buffer must be from 0 to the extent ({e}), got {b}")
    return e, b


def _check_tile(z, x, y) -> tuple[int, int, int]:
    z = check_zoom(z)
    for name, v in (("x", x), ("y", y)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
            raise InvalidGridError(f"tile {name} must be an integer, got {v!r}")
        if not 0 <= int(v) < (1 << z):
            raise InvalidGridError(
                f"tile {name} must be from 0 to {(1 << z) - 1} at zoom {z}, got {v}"
            )
    return z, int(x), int(y)


def frame_rings(boundary, frame: TileFrame, pieces=None, points=None):
    """Return the region's rings inside one frame's rectangle and whether any crossed it.

    Where none crossed, the rectangle's status decides (:func:`boxed`). ``points``: the
    :class:`~gloffset.mvt.densify.ZoomPoints` of the boundary's arcs at the frame's
    zoom when a pyramid has them (the same points near the rectangle).
    """
    if pieces is None:
        pieces = boundary.pieces(frame.cap())
    polylines = []
    world = (1 << frame.z) * frame.extent
    for q, s, e, closed, ids in pieces.chains:
        if points is not None and ids is not None:
            xyz, uv = points.chain(ids, frame)
        else:
            arcs = densify(frame, q, s, e)
            xyz = np.vstack([a[0][:-1] for a in arcs] + [arcs[-1][0][-1:]])
            uv = np.vstack([a[1][:-1] for a in arcs] + [arcs[-1][1][-1:]])
        if closed:
            xyz, uv = xyz[:-1], uv[:-1]
        jump = np.flatnonzero(np.abs(np.diff(uv[:, 0])) > 0.5 * world)
        if closed and abs(uv[0, 0] - uv[-1, 0]) > 0.5 * world:
            jump = np.concatenate([jump, [len(uv) - 1]])
        if len(jump) == 0:
            polylines.append((uv, xyz, closed))
            continue
        if closed:  # start after a jump: the ring becomes open pieces
            k = int(jump[0]) + 1
            uv, xyz = np.roll(uv, -k, axis=0), np.roll(xyz, -k, axis=0)
            jump = np.flatnonzero(np.abs(np.diff(uv[:, 0])) > 0.5 * world)
        for part_uv, part_xyz in zip(np.split(uv, jump + 1), np.split(xyz, jump + 1)):
            if len(part_uv) >= 2:
                polylines.append((part_uv, part_xyz, False))
    return clip_rings(polylines, frame, pieces.keep)


def corner(frame: TileFrame) -> np.ndarray:
    """Return the point whose membership decides a rectangle no boundary crosses."""
    u0, v0, _, _ = frame.rect
    return frame.unproject([[u0, v0]])


def boxed(rings: list, frame: TileFrame, inside: bool) -> list:
    """Return ``rings`` with the whole rectangle added when its corner is inside."""
    if inside:
        u0, v0, u1, v1 = frame.rect
        box = np.array([[u0, v1], [u1, v1], [u1, v0], [u0, v0], [u0, v1]], dtype=np.float64)
        rings = [*rings, box]
    return rings


def _frame_geometry(boundary, frame: TileFrame, pieces=None):
    """Return the region inside one frame's rectangle as rings (the box when inside)."""
    rings, crossed = frame_rings(boundary, frame, pieces)
    if not crossed:
        rings = boxed(rings, frame, bool(boundary.contains(corner(frame))[0]))
    return rings


def tile_geometry(
    boundary, z: int, x: int, y: int, extent: int = 4096, buffer: int = 64, *, pieces=None
):
    """Return the region in tile ``z/x/y`` as a valid shapely (Multi)Polygon.

    In integer tile coordinates (``v`` down), or None where the tile holds none of it.

    ``boundary`` is a :class:`~gloffset.mvt.boundary.LocalBoundary` or
    :class:`~gloffset.mvt.boundary.ResolvedBoundary`; ``pieces`` its
    :class:`~gloffset.mvt.boundary.Pieces` for the tile when already found (not at zoom 0).
    """
    if z == 0:  # the world's seam runs along the tile's sides: two halves, then their union
        import shapely

        halves = []
        for u_range in ((0.0, extent / 2), (extent / 2, float(extent))):
            frame = TileFrame.of(0, 0, 0, extent, buffer, u_range=u_range)
            g = to_polygons(_frame_geometry(boundary, frame))
            if g is not None:
                halves.append(g)
        if not halves:
            return None
        g = shapely.unary_union(halves) if len(halves) > 1 else halves[0]
        return g if g.area > 0 else None
    frame = TileFrame.of(z, x, y, extent, buffer)
    return to_polygons(_frame_geometry(boundary, frame, pieces))


def boundary_for(shape, d: float, z: int, x: int, y: int, extent: int, buffer: int):
    """Return ``(boundary, pieces)`` for one tile at angle ``d``.

    The resolved boundary where it is kept on the shape, at zoom 0, or where the edges
    near the tile exceed :data:`LOCAL_SHARE` of the input's (``pieces`` None then);
    otherwise the local boundary and its pieces for the tile. Both give the same tile.
    """
    kept = shape.derived.mvt_boundaries
    if d in kept or z == 0:
        return ResolvedBoundary.of(shape, d), None
    local = LocalBoundary(shape, d)
    cap = TileFrame.of(z, x, y, extent, buffer).cap()
    items = local.edges_near(cap)
    if len(items) > LOCAL_SHARE * max(len(local.arcs.a), 1):
        return ResolvedBoundary.of(shape, d), None
    return local, local.pieces(cap, items)


def encode(geom, layer: str, properties: dict, extent: int) -> bytes:
    """Return one MVT tile with one layer holding ``geom`` as one feature.

    ``geom`` in integer tile coordinates (``v`` down); None gives a layer without features.
    """
    import mapbox_vector_tile
    from mapbox_vector_tile.encoder import on_invalid_geometry_raise

    features = [] if geom is None else [{"geometry": geom, "properties": properties}]
    return mapbox_vector_tile.encode(
        {"name": layer, "features": features},
        default_options={
            "extents": extent,
            "y_coord_down": True,
            "on_invalid_geometry": on_invalid_geometry_raise,
        },
    )


def vector_tile(
    shape,
    distance,
    z: int,
    x: int,
    y: int,
    *,
    extent: int = 4096,
    buffer: int = 64,
    layer: str | None = None,
    radius: float = EARTH_RADIUS,
    tms=None,
) -> bytes:
    """One Mapbox Vector Tile (MVT 2.1) of the region within ``distance`` of ``shape``.

    Parameters
    ----------
    shape : Shape or anything :func:`gloffset.read` accepts
    distance : float or str
        In the units of ``radius`` or with a unit (``"127km"``); negative shrinks the
        polygons. Less than a quarter of a great circle in absolute value.
    z, x, y : int
        The web-mercator XYZ tile (y = 0 at the north).
    extent : int
        Tile units across the tile (a power of two, 256 to 65536).
    buffer : int
        Tile units kept beyond each side of the tile (0 to ``extent``).
    layer : str, optional
        The layer's name (default ``"offset"``).
    tms : None or "WebMercatorQuad"
        The tile matrix set; only web mercator is supported.

    Returns
    -------
    bytes
        The tile: one layer, one polygon feature (none where the tile holds none of the
        region) with properties ``distance_m`` and ``distance``, as the vector outputs
        name them.

    Notes
    -----
    Accuracy: every vertex that does not lie on the edge of the buffered tile lies
    within 0.71 units of the exact boundary (on it before rounding to integers); no
    straight edge strays more than 0.63 units from it before rounding (1.4 after), so a
    point 2 units or more from the boundary lies on its right side. No vertex is kept
    where a straight segment would stay within half a unit. Rings follow the MVT 2.1
    rules after rounding: exteriors clockwise, holes counter-clockwise (``y`` down), no
    self-intersection, no zero area. At a distance whose resolved boundary is kept
    on the shape (:class:`gloffset.mvt.boundary.ResolvedBoundary`, the last few) the tile
    is cut from it; otherwise, where the tile reaches a small share of the input's
    edges, only those edges are offset and resolved
    (:class:`gloffset.mvt.boundary.LocalBoundary`), so its cost follows the edges near
    the tile; otherwise the whole offset is resolved (:meth:`gloffset.Offset.resolve`)
    and kept. Both give the same tile.
    """
    if tms not in (None, "WebMercatorQuad"):
        raise OptionError(
            f"vector tiles are made in web mercator (WebMercatorQuad), got tms={tms!r}"
        )
    extent, buffer = check_mvt_options(extent, buffer)
    z, x, y = _check_tile(z, x, y)
    shape = read(shape)
    r = check_radius(radius)
    d = offset_angle(shape, distance, r, limit=VECTOR_LIMIT)
    boundary, pieces = boundary_for(shape, d, z, x, y, extent, buffer)
    geom = tile_geometry(boundary, z, x, y, extent, buffer, pieces=pieces)
    return encode(geom, layer or DEFAULT_LAYER, distance_properties(distance, r), extent)
