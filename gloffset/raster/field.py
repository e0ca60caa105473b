"""Signed distance fields: every distance at once (``distance_field(shape, grid)``).

The region of a shape at signed distance ``d`` is ``{s <= d}`` (``{s < d}`` for ``d < 0``),
where ``s(p)`` is the great-circle distance from ``p`` to the shape's curves, negated
inside the union of its polygons (lines and points bound no region: their ``s`` is
never negative). ``s`` does not depend on ``d``, so one field answers every distance:
:meth:`DistanceField.threshold` gives the mask of :func:`gloffset.render` at any ``d``.

How it is computed: a walk over the grid's levels, coarse to fine, every cell with a
list of candidate nodes of the multiresolution tree (paper Sec. 4.2, Eq. 9 bounds),
pruned by bounds and by a bisector test, down to the original edges at the pixels,
each pixel ending with the exact float64 distance of its nearest arc
(:mod:`gloffset.raster.fields.walk`). With ``backend="gpu"`` the walk stops at cells of
8 x 8 pixels and one compute shader does each pixel: its centre, its candidates ranked
in float32 and the near-least finished in float64 (:mod:`gloffset.raster.fields.gpu`).
The sign is the inside status of the float64 render at distance 0, read from each
pixel's nearest boundary features (:mod:`gloffset.raster.fields.sign`; on the GPU in the
same shader, the few pixels its float32 margins leave open by the float64 rule on the
host), the levels' test only on the pixels that leaves undecided (``docs/design.md``
has the derivation).

Accuracy: each value is the float64 distance (exact to 1e-15 rad; on the GPU within
:data:`~gloffset.gl.field_pass.FIELD_ERR`, 1.5e-15, relative) times ``radius``, clamped
to ``[-max_distance, max_distance]`` and rounded to float32 once: within 1 float32 ulp
of the exact signed distance. A threshold compares the float32 values
with ``d``; pixels whose value lies within two float32 spacings of ``d`` are decided
again in float64 (their distance against the arcs whose caps reach, the predicate
the renders settle their band with, :func:`gloffset.raster.simplified.band_members`;
their inside status is the sign bit of the value, kept exactly: ``-0.0`` inside).
"""

from __future__ import annotations

import math

import numpy as np

from ..edges import CurveArcs
from ..errors import OptionError
from ..grids.protocol import Image
from ..shape import read
from ..units import (
    EARTH_RADIUS,
    RASTER_LIMIT,
    check_radius,
    offset_angle,
    parse_length,
    to_angle,
)
from .fields.gpu import gpu_distances
from .fields.sign import (
    INSIDE,
    NEAR,
    UNDECIDED,
    Corners,
    block_signs,
    levels_inside,
    nearest_signs,
)
from .fields.walk import walk_levels
from .render import MAX_PIXELS
from .simplified import band_members
from .vector.node_levels import NodeArcs

__all__ = ["DistanceField", "check_field_grid", "distance_field"]

_BACKENDS = ("gpu", "cpu")

#: Pixels decided again in float64 per batch of :meth:`DistanceField.threshold`.
_BATCH = 1 << 16


class DistanceField:
    """The signed distance field of a shape on a grid (:func:`distance_field`).

    Attributes
    ----------
    values : numpy.ndarray
        float32, the grid's shape (``Equirect``: (height, width); ``Tile``: (size,
        size); ``Cube``: (6, size, size), faces as :func:`gloffset.render` stacks them):
        the signed great-circle distance of each pixel centre to the curves, in the
        units of ``radius``, negative inside the union of the polygons, clamped to
        ``[-max_distance, max_distance]``. Each is the exact float64 value rounded
        once to float32 (within 1 float32 ulp).
    grid : the grid
    radius : float
    max_distance : float or None
    """

    def __init__(self, shape, grid, values: np.ndarray, radius: float, max_distance):
        self.shape = shape
        self.grid = grid
        self.values = values
        self.radius = radius
        self.max_distance = max_distance

    def __repr__(self) -> str:
        return (
            f"DistanceField({type(self.grid).__name__}, values {self.values.shape} float32, "
            f"radius={self.radius!r}, max_distance={self.max_distance!r})"
        )

    def threshold(self, d: float | str) -> np.ndarray:
        """Return the mask of the region at signed distance ``d``.

        ``d`` is a number in the units of ``radius`` or a string with a unit (``"127km"``,
        ``"-50km"``, ``"0.02rad"``), as every public function takes it.

        uint8, 255 inside, 0 outside, in the shape of :attr:`values`.

        A pixel is in when its exact signed distance is ``<= d`` (``< d`` for ``d < 0``);
        pixels whose float32 value cannot tell are decided in float64. So the mask is
        ``gloffset.render(shape, d, grid, radius=radius, backend="cpu")`` (the float64
        reference renderer) byte for byte, and the GPU render's wherever that render
        equals the reference: everywhere but at pixels whose exact distance is within
        its stated error (1e-3 of a pixel) of ``|d|`` or of a polygon boundary.

        Raises :class:`~gloffset.errors.InvalidDistanceError` for a ``d`` that
        ``render`` refuses, and :class:`~gloffset.errors.OptionError` when ``|d|``
        exceeds ``max_distance`` (the field does not know the pixels beyond it).
        """
        e = offset_angle(self.shape, d, self.radius, limit=RASTER_LIMIT, what="render")
        given = d
        d = parse_length(d, self.radius)  # in the units of radius, as the values
        if self.max_distance is not None and abs(d) > self.max_distance:
            raise OptionError(
                f"threshold distance {given!r} is beyond the field's max_distance "
                f"{self.max_distance!r}; compute the field with a larger max_distance"
            )
        flat = self.values.reshape(-1, self.values.shape[-1])  # rows of every face
        cut, lo, hi = _cuts(d)
        mflat = (flat <= cut) if d >= 0 else (flat < cut)
        # a superset of the values within two float32 spacings of d (at the larger of
        # |x| and |d|: a value that far has |x| < 2 |d|, so its spacing is at most twice
        # d's), decided again in float64
        amb = (flat >= lo) & (flat <= hi)
        if amb.any():
            j, i = np.nonzero(amb)
            mflat[j, i] = self._settle(j, i, e)
        member = mflat.reshape(self.values.shape)
        return np.where(member, np.uint8(255), np.uint8(0))

    def _settle(self, rows: np.ndarray, cols: np.ndarray, e: float) -> np.ndarray:
        """Return the membership at signed angle ``e`` of pixels, decided in float64.

        The pixels are given as flat rows of every face and columns.
        """
        size = self.values.shape[-2]
        out = np.empty(len(rows), dtype=bool)
        inside = np.signbit(self.values.reshape(-1, self.values.shape[-1])[rows, cols])
        grids = self.grid.faces
        face, j = np.divmod(rows, size)
        for k, g in enumerate(grids):
            sel = np.flatnonzero(face == k)
            if not len(sel):
                continue
            p = g.centers(g.n_levels - 1, j[sel], cols[sel])
            out[sel] = _members(self.shape, p, inside[sel], e)
        return out


def _cuts(d: float) -> tuple[np.float32, np.float32, np.float32]:
    """Return float32 numbers ``cut``, ``lo``, ``hi`` for comparing float32 values with ``d``.

    For every float32 ``x``: ``x <= cut`` iff ``x <= d`` (``d >= 0``: ``cut`` is the largest
    float32 not above ``d``), ``x < cut`` iff ``x < d`` (``d < 0``: the smallest not below
    it); ``[lo, hi]`` holds ``d`` +- 4 float32 spacings of ``|d|``, rounded outwards.
    """
    c = np.float32(d)
    if d >= 0 and float(c) > d:
        c = np.nextafter(c, np.float32(-np.inf))
    elif d < 0 and float(c) < d:
        c = np.nextafter(c, np.float32(np.inf))
    w = 4.0 * float(np.spacing(np.float32(abs(d))))
    lo, hi = np.float32(d - w), np.float32(d + w)
    if float(lo) > d - w:
        lo = np.nextafter(lo, np.float32(-np.inf))
    if float(hi) < d + w:
        hi = np.nextafter(hi, np.float32(np.inf))
    return c, lo, hi


def _members(shape, p: np.ndarray, inside: np.ndarray, e: float) -> np.ndarray:
    """Return the members at signed angle ``e`` among points ``p`` of known inside status.

    Inside, or within ``e`` (``e >= 0``); inside and farther than ``|e|`` (``e < 0``),
    with the exact float64 distances of :func:`band_members`.
    """
    out = inside.copy()
    todo = np.flatnonzero(inside if e < 0 else ~inside)
    for s in range(0, len(todo), _BATCH):
        part = todo[s : s + _BATCH]
        # band_members(d) is "within |d|" for d > 0 and "farther than |d|" for d <= 0
        got = band_members(shape, p[part], e)
        out[part] = got if e != 0 else ~got
    return out


def ellipsoid_refusal(ellipsoid) -> str:
    """Return the message that refuses a field on ``ellipsoid``, with the measured reason.

    A value within 2 float32 ulps of the geodesic distance needs a geodesic intercept
    (:mod:`gloffset.ellipsoid.intercept`) at every pixel at least; that alone, 6 us a
    pixel on PROJ's geodesics, is 3.2 times the whole spherical field of the 1:10m
    countries at 4096 x 2048 (``benchmarks/field_ellipsoid.py``), over the 3 times the
    field was allowed.
    """
    return (
        f"distance_field does not support ellipsoid={ellipsoid!r}: exact geodesic values "
        "need a geodesic intercept per pixel, over 3 times the spherical field's time "
        "(benchmarks/field_ellipsoid.py); use the sphere (ellipsoid=None) for the field, or "
        "gloffset.render(..., ellipsoid=...) and gloffset.distance(..., ellipsoid=...) for "
        "geodesic regions and distances"
    )


def check_field_grid(grid) -> None:
    """Refuse a grid :func:`distance_field` cannot take, before any work.

    Raises :class:`~gloffset.errors.OptionError` for something that is not a
    ``gloffset.grids`` grid, or one of more than :data:`~gloffset.raster.render.MAX_PIXELS`
    pixels (the limit of :func:`gloffset.render`: the field's float32 values alone would
    be 8 GiB, its work about 50 bytes a pixel).
    """
    if not isinstance(grid, Image):
        raise OptionError(
            f"grid must be a gloffset.grids grid (Equirect, Tile, Cube), got {type(grid).__name__}"
        )
    n = sum(f.width * f.height for f in grid.faces)
    if n > MAX_PIXELS:
        raise OptionError(
            f"the field has {n} pixels, more than {MAX_PIXELS}; compute it in parts "
            "(Equirect.subgrid, or fewer cube pixels)"
        )


def _max_distance(max_distance, radius: float) -> tuple[float, float | None]:
    """``max_distance`` as an angle (``inf`` for None) and in the units of ``radius``.

    A number in the units of ``radius`` or a string with a unit (``"500km"``); a clear
    error unless it is a positive distance.
    """
    if max_distance is None:
        return math.inf, None
    m = to_angle(max_distance, radius)
    if not m > 0.0:
        raise OptionError(f"max_distance must be a positive distance, got {max_distance!r}")
    return m, parse_length(max_distance, radius)


def distance_field(
    shape,
    grid,
    *,
    max_distance: float | None = None,
    radius: float = EARTH_RADIUS,
    ellipsoid=None,
    progress=None,
    backend: str = "gpu",
) -> DistanceField:
    """Return the signed distance field of ``shape`` on ``grid``.

    Parameters
    ----------
    shape : Shape or anything :func:`gloffset.read` accepts
    grid : gloffset.grids.Equirect, Tile, Cube or CubeFace
    max_distance : float or str, optional
        Clamp the field to ``[-max_distance, max_distance]`` (a number in the units of
        ``radius``, or a string with a unit: ``"500km"``); the work then follows the band
        within it (cells wholly beyond it cost no pixel work).
    radius : float
        Sphere radius; the values are in its units (metres by default).
    ellipsoid : None
        Only the sphere: any other value raises :class:`~gloffset.errors.OptionError`
        (:func:`ellipsoid_refusal` says why).
    progress : callable, optional
        Called as ``progress(done, total)`` as the work goes on: ``done`` rises to
        ``total``, in pixels (those whose distances are final, then, for a shape with
        polygons, those whose sign is, all at once).
    backend : {"gpu", "cpu"}
        Where the pixels' nearest arcs are found: ``"gpu"`` (the GL context's compute
        shader, ranked in float32, finished in float64) or ``"cpu"`` (in float64). The
        values agree within 1 float32 ulp, with the same signs (nearly all bit for bit:
        the float64 distances differ by at most ``FIELD_ERR`` relative); the walk above
        the pixels runs on the CPU either way, and the sign is read from the pixels'
        nearest features by either (``"gpu"`` in its compute shader), the levels'
        inside test settling the few pixels that leaves open: the same signs.

    Raises
    ------
    OptionError
        Before any work: a grid that is not a ``gloffset.grids`` grid or has more than
        :data:`~gloffset.raster.render.MAX_PIXELS` pixels, a ``max_distance`` that is not
        positive, another ``ellipsoid`` or ``backend``.
    InvalidDistanceError
        Before any work: a ``max_distance`` that is not a distance (``"500 parsecs"``).

    Returns
    -------
    DistanceField
        ``.values`` float32 in the grid's shape (as :func:`gloffset.render`'s mask):
        negative inside the union of the polygons, unsigned for lines and points.

    Notes
    -----
    Accuracy: every value is the exact float64 signed distance (error below 1e-15 rad
    times ``radius``) rounded once to float32, so within 1 float32 ulp of the exact
    value; its sign is the inside status of the levels' crossing parity, as in the
    float64 reference renderer. ``threshold(d)`` equals ``render(shape, d, grid)`` (see
    :meth:`DistanceField.threshold`) with either backend. The backends' values agree
    within 1 float32 ulp (the GPU's float64 distances within ``FIELD_ERR``, 1.5e-15,
    relative of the CPU's from the same centre: bit for bit but where one lies that
    near a float32 rounding boundary); on grids with a GLSL function of their centres
    the GPU's centres are that function's, within its stated bound of the host's.
    Cost: the output pixels, each against the few arcs that can be its nearest (see the
    module notes). ``"cpu"``: the walk to the pixels in float64, 3 to 4 times the floor
    of the same walk with one candidate arc per cell, plus the sign from the nearest
    features.
    ``"gpu"``: the walk stops at cells of 8 x 8 pixels; the GPU makes each pixel's
    centre, ranks its candidates in float32 and finishes one float64 distance per
    pixel (a few, or the cell's list, where the float32 values cannot rank them): the
    host hands over the lists and reads back the distances (``benchmarks/field.py``).
    """
    if ellipsoid is not None:
        raise OptionError(ellipsoid_refusal(ellipsoid))
    if backend not in _BACKENDS:
        raise OptionError(f"backend must be one of {', '.join(_BACKENDS)}, got {backend!r}")
    radius = check_radius(radius)
    check_field_grid(grid)
    m, max_units = _max_distance(max_distance, radius)
    shape = read(shape)
    count = _Progress(progress, grid, bool(shape.rings))
    if grid.n_faces > 1:
        values = np.stack([_field(shape, f, m, radius, count, backend) for f in grid.faces])
    else:
        values = _field(shape, grid, m, radius, count, backend)
    return DistanceField(shape, grid, values, radius, max_units)


class _Progress:
    """The count of :func:`distance_field`'s ``progress``.

    Pixels of the distance walk, then (with polygons) the pixels' signs, all at once.
    """

    def __init__(self, callback, grid, signed: bool):
        self.callback = callback
        pixels = sum(math.prod(f.level_shape(f.n_levels - 1)) for f in grid.faces)
        self.total = pixels * (2 if signed else 1)
        self.done = 0

    def add(self, n: int) -> None:
        if self.callback is not None and n:
            self.done += int(n)
            self.callback(self.done, self.total)


def _field(shape, grid, m: float, radius: float, count: _Progress, backend: str) -> np.ndarray:
    """Return the float32 field of one grid (clamped to ``+-m`` rad, ``m`` may be inf).

    The unsigned distances, negated where the levels' float64 render at distance 0
    (:func:`gloffset.raster.vector.curves.classify_curves`) has the pixel inside (a pixel
    on the curves has the value 0 either way), that status read from the pixels' nearest
    features: by the GPU backend's shader (:func:`_gpu_inside`), by the CPU backend
    from its walk (:func:`_distances`).
    """
    signed = bool(shape.rings)
    if backend == "gpu" and grid.n_levels > 1:
        codes = np.empty(grid.level_shape(grid.n_levels - 1), dtype=np.uint32) if signed else None
        dist = gpu_distances(shape, grid, m, count.add, codes=codes)
        inside = np.zeros(dist.shape, dtype=bool)
        if codes is not None:
            inside = _gpu_inside(shape, grid, m, dist, codes)
            count.add(dist.size)  # the signs, all at once
    else:
        dist, inside = _distances(shape, grid, m, count, signed)
    v = np.minimum(dist, m, out=dist)
    v *= radius
    out = v.astype(np.float32)  # rounded alike either sign: negated after
    np.negative(out, out=out, where=inside)
    valid = grid.valid(grid.n_levels - 1)
    if valid is not None:  # pixels without a place on the sphere: farther than any d
        out[~valid] = np.inf
    return out


def _gpu_inside(shape, grid, m: float, dist: np.ndarray, codes: np.ndarray) -> np.ndarray:
    """Return the pixels' inside status from the shader's sign codes.

    ``codes`` as :func:`~gloffset.raster.fields.gpu.gpu_distances` fills them; a pixel
    at distance 0 is inside; one undecided by the shader gets the float64 rule from its
    nearest features found on the host (:func:`~gloffset.raster.fields.sign.nearest_signs`;
    the shader's float32 rule leaves a few pixels open that it decides); one within
    ``NEAR`` of the boundary, beyond ``m`` or still undecided gets the float64 levels'
    test (:func:`~gloffset.raster.fields.sign.levels_inside`, only its ancestors
    walked; none where nothing is undecided). The inside status of
    ``classify_curves(shape, 0.0, grid)``, bit for bit.
    """
    zero = dist == 0.0
    und = np.greater(dist, NEAR)
    und &= dist <= m
    np.logical_not(und, out=und)
    und |= codes == UNDECIDED
    und &= ~zero
    inside = np.equal(codes, INSIDE)
    inside |= zero
    j, i = np.nonzero(und)
    if len(j):  # the float64 rule first: the levels' walk is the dearer
        near = np.where(dist[j, i] <= m, dist[j, i], np.inf)
        c = grid.centers(grid.n_levels - 1, j, i)
        ins, left = nearest_signs(shape, c, near)
        inside[j, i] = ins
        j, i = j[left], i[left]
    if len(j):
        inside[j, i] = levels_inside(shape, grid, j, i)
    return inside


def _distances(shape, grid, m: float, count: _Progress, signed: bool):
    """Return each pixel centre's distance (rad, float64) to the nearest arc, and status.

    The status: whether the pixel is inside (all False unless ``signed``). The distance
    is exact where it is at most ``m`` (larger than ``m`` elsewhere): the levels walked
    depth first with lists of nodes of the multiresolution tree
    (:func:`~gloffset.raster.fields.walk.walk_levels`) down to the output pixels. The
    inside status is read from each pixel's nearest features
    (:func:`~gloffset.raster.fields.sign.block_signs`); the pixels that rule leaves undecided
    get the float64 levels' test at distance 0
    (:func:`~gloffset.raster.fields.sign.levels_inside`): the inside status of
    ``classify_curves(shape, 0.0, grid)``, bit for bit.
    """
    nodes = NodeArcs.from_shape(shape)
    last = grid.n_levels - 1
    h, w = grid.level_shape(last)
    out = np.full((h, w), np.inf)
    inside = np.zeros((h, w), dtype=bool)
    if not signed:
        for f, dist in walk_levels(nodes, grid, m, last):
            out[f.cells[:, 0], f.cells[:, 1]] = dist
            count.add(len(f.cells))
        return out, inside
    corners, arcs = Corners.from_shape(shape), CurveArcs.from_shape(shape)
    undecided = []
    for f, dist, pairs in walk_levels(nodes, grid, m, last, pairs=True):
        j, i = f.cells[:, 0], f.cells[:, 1]
        out[j, i] = dist
        known = np.where(dist <= m, dist, np.inf)  # beyond m: no nearest arc known
        ins, und = block_signs(corners, arcs, grid, f, known, pairs)
        inside[j, i] = ins
        undecided.append(f.cells[und])
        count.add(len(f.cells))
    cells = np.concatenate(undecided)
    inside[cells[:, 0], cells[:, 1]] = levels_inside(shape, grid, cells[:, 0], cells[:, 1])
    count.add(h * w)
    return out, inside
