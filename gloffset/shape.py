"""Input geometry as float64 unit vectors: closed rings (with holes) and open lines.

A :class:`Shape` is what every other part of gloffset consumes. It is built once,
here, from GeoJSON, a shapely object or lon/lat arrays, and validated once: NaN or
infinite coordinates, latitudes outside [-90, 90], parts with fewer than two
distinct points and consecutive antipodal points (whose great circle is undefined)
raise :class:`~gloffset.errors.InvalidGeometryError` naming the feature, part and
vertex. Repeated consecutive points are dropped.

The region. Polygons of one input are united: the region is the union of the input's
polygons, and its boundary (derived once, by :mod:`gloffset.region`) is what every
operation measures from. Seams (edges along +-180 deg or at a pole; vertices within
1e-9 deg of them snapped) take part in the union and close their rings, but have no
distance, offset or outline. Lines and points stay curves.

Orientation. Every ring is stored with its interior on the left of its direction
of travel on the sphere: exterior rings are made counter-clockwise and holes
clockwise in lon/lat (as RFC 7946 asks; input winding is not trusted), which is the
same as "interior on the left" on the sphere. A ring round a pole encloses the pole
on its side of the equator; a ring through a pole (a vertex on it, an edge whose ends
lie 180 deg of longitude apart) passes through it; any other ring bounds the side that
holds neither pole, by its area on the sphere (:func:`gloffset.geometry.lonlat.is_ccw`);
a polygon whose edges cross (a bowtie) is read by crossing parity.

Limits. Longitudes must lie in [-180, 180] and latitudes in [-90, 90] (no
wrapping: 400 is an error, not 40). A ring that covers the whole sphere (it runs
only along +-180 deg and the poles) leaves no boundary and is refused, unless
holes give it one. The derivation in full: ``docs/design.md``, *Module notes*.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from .errors import InputFormatError, InvalidGeometryError
from .geometry.caps import arc_cap, pad
from .geometry.lonlat import prepare_rings, validate
from .geometry.sphere import (
    angle,
    arc_distance,
    arcs_cross,
    dot,
    normalize,
    robust_cross,
)
from .io import features as _features
from .io import geojson as _gj
from .io.crs import densify_tolerance as _densify_tolerance
from .memo import MISSING, Locks, Memo, freeze
from .region import unite

if TYPE_CHECKING:
    from .edges import CurveArcs

__all__ = ["Shape", "Derived", "Edges", "read"]

# Two reference points with a known inside/outside status per region component;
# a query uses the first unless it is nearly antipodal to it.
T = TypeVar("T")

_REF = normalize(np.array([[0.2897, -0.4671, 0.8353], [0.8071, 0.5663, -0.1672]]))


@dataclass(frozen=True)
class Edges:
    """All edges of a shape as flat arrays (what the reference and the GPU consume).

    Attributes
    ----------
    a, b : (m, 3) float64
        Start and end of each great-circle arc (``a == b`` for an isolated point).
    boundary : (m,) bool
        False for seams: they close rings for the inside test but have no distance.
    group : (m,) int
        Region component of ring edges (for crossing parity); -1 for edges of lines
        and points, which bound no region.
    """

    a: np.ndarray
    b: np.ndarray
    boundary: np.ndarray
    group: np.ndarray

    def __len__(self) -> int:
        return len(self.a)


class Derived:
    """What is derived from a shape and kept for its life, safe to share between threads.

    One named slot per index, each filled on first use by the one module that owns it
    (named per slot), never by another, and only through :meth:`once` (a single value) or
    the slot's :class:`~gloffset.memo.Memo` (values by key): each is built once, under a
    lock of its own, however many threads ask at the same time, and read without a lock
    once built (:mod:`gloffset.memo`). Assigning a slot is an error.

    Shapes are not changed after construction, so nothing here goes stale. A pickled shape
    leaves all of it out (:meth:`Shape.__getstate__`): it is rebuilt where needed, and a
    shape sent to worker processes stays the size of its input. Slots of types from upper
    layers are typed ``Any`` (this layer does not import them); their owners say the type.
    """

    #: The single slots (None until built): the shape's own edge table, reference
    #: statuses and overlapping components (:class:`Shape`);
    #: :class:`gloffset.edges.CurveArcs` (``CurveArcs.from_shape``), the edge index;
    #: the distinct ends of the boundary arcs (:func:`gloffset.edges.distance_xyz`);
    #: the judge's ring edges and its edge index (:mod:`gloffset.reference`, which
    #: shares nothing with the others); crossing and overlapping rings
    #: (:func:`gloffset.vector.arrangement.defects`); the exhaustive multiresolution
    #: decomposition (:mod:`gloffset.vector.multires`); the inside test's arcs
    #: (:mod:`gloffset.index.arcs`); the multiresolution arcs of a pyramid's coarse levels
    #: (:mod:`gloffset.raster.vector.node_levels`); the least distance from the reference
    #: points to the ring edges (:mod:`gloffset.raster.simplified`); the shape as GeoJSON
    #: bytes, for the tile server's page (:mod:`gloffset.serve.app`); the corners of the
    #: rings that a distance field's sign reads (:mod:`gloffset.raster.fields.sign`).
    SINGLE = (
        "edges",
        "ref_status",
        "overlap",
        "arcs",
        "boundary_vertices",
        "reference_rings",
        "reference_index",
        "defects",
        "exhaust",
        "contains_arcs",
        "node_arcs",
        "ref_clearance",
        "serve_geojson",
        "field_sign",
    )
    #: The slots of values by key (:class:`~gloffset.memo.Memo`): anchor points and their
    #: component statuses, by count (:func:`gloffset.geometry.crossings.inside_indexed`);
    #: the judge's densified geodesic rings by ``(a, f)`` (:mod:`gloffset.reference`); the
    #: inside test's indexes, by ``(distance, level)``, the last few
    #: (:mod:`gloffset.index.contains`); the shape on an ellipsoid's conformal sphere, by
    #: ``(a, f)`` (:mod:`gloffset.ellipsoidal`); the curves simplified to a tolerance, by
    #: tolerance, None where that does not pay (:mod:`gloffset.raster.simplified`); the
    #: boxes of the region at each distance the tile server reported, the last few
    #: (:mod:`gloffset.serve.bounds`); the resolved boundaries of vector tiles, by distance,
    #: the last few (:mod:`gloffset.mvt.boundary`).
    KEYED = (
        "anchors",
        "reference_geodesic",
        "contains_indexes",
        "conformal",
        "simplified",
        "serve_bounds",
        "mvt_boundaries",
    )
    __slots__ = (*SINGLE, *KEYED, "_locks")

    edges: Edges | None
    ref_status: np.ndarray | None
    overlap: np.ndarray | None
    arcs: Any
    boundary_vertices: np.ndarray | None
    reference_rings: tuple | None
    reference_index: Any
    defects: tuple[bool, bool] | None
    exhaust: Any
    contains_arcs: Any
    node_arcs: Any
    ref_clearance: float | None
    serve_geojson: bytes | None
    field_sign: Any
    anchors: Memo
    reference_geodesic: Memo
    contains_indexes: Memo
    conformal: Memo
    simplified: Memo
    serve_bounds: Memo
    mvt_boundaries: Memo
    _locks: Locks

    def __init__(self) -> None:
        for name in self.SINGLE:
            object.__setattr__(self, name, None)
        for name in self.KEYED:
            object.__setattr__(self, name, Memo())
        object.__setattr__(self, "_locks", Locks())

    def __setattr__(self, name: str, value) -> None:
        raise AttributeError(
            f"Derived.{name} is built once, through Derived.once or the slot's Memo"
        )

    def once(self, name: str, build: Callable[[], T]) -> T:
        """Return the single slot ``name``, built by ``build()`` on first use.

        Built once, under the slot's lock; a built slot is read without one.
        """
        got = getattr(self, name)
        if got is not None:
            return got

        def check():
            got = getattr(self, name)
            return MISSING if got is None else got

        def make():
            value = freeze(build())
            object.__setattr__(self, name, value)
            return value

        return self._locks.run(name, check, make)

    def __reduce__(self):
        # what was derived is never pickled: a copy starts empty
        return (Derived, ())


@dataclass
class Shape:
    """Curves and polygons on the unit sphere.

    Attributes
    ----------
    rings : list of (n, 3) float64 arrays
        Closed rings (first vertex not repeated), interior on the left.
    ring_seams : list of (n,) bool arrays
        ``ring_seams[k][i]`` is True when edge ``i -> i+1`` of ring ``k`` is a seam.
    ring_groups : (len(rings),) int array
        Region component of each ring: an exterior with its holes, or pieces of one
        polygon joined across the antimeridian. Components are united (a point is
        inside the shape when it is inside any component).
    ring_holes : (len(rings),) bool array
        True for the holes of a polygon, False for exterior rings.
    lines : list of (n, 3) float64 arrays
        Open lines (n >= 2) and isolated points (n == 1).
    labels : list of str
        Where each ring and then each line came from, for messages.
    source : Parts or None
        The polygons, lines and points as the user gave them (validated lon/lat,
        rings closed and oriented), written back by :meth:`to_geojson`.
    """

    rings: list[np.ndarray] = field(default_factory=list)
    ring_seams: list[np.ndarray] = field(default_factory=list)
    ring_groups: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    ring_holes: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    lines: list[np.ndarray] = field(default_factory=list)
    labels: list[str] = field(default_factory=list)
    source: _gj.Parts | None = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        self.ring_groups = np.asarray(self.ring_groups, dtype=np.int64)
        self.ring_holes = np.asarray(self.ring_holes, dtype=bool).reshape(len(self.rings))
        if not self.rings and not self.lines:
            raise InvalidGeometryError("empty geometry: no polygon, line or point to offset")
        #: what is derived from the shape, by it and by other modules (:class:`Derived`)
        self.derived = Derived()

    def __getstate__(self):
        # what was derived from the shape is left out of a pickle: it is rebuilt where
        # needed, and a shape sent to worker processes stays the size of its input
        state = dict(self.__dict__)
        state["derived"] = Derived()
        return state

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_geojson(cls, obj, *, layer=None, where: str | None = None, densify=None) -> Shape:
        """Build a shape from a GeoJSON object (dict) or anything :func:`read` accepts."""
        with _gj.collector_paused():  # the document freed before the collector runs
            parts = _gj.parse(_features.load(obj, layer=layer, where=where, densify=densify))
        return _from_parts(parts)

    @classmethod
    def from_lonlat(cls, lon, lat, *, closed: bool = False) -> Shape:
        """Return a single line (``closed=False``) or polygon ring (``closed=True``) from arrays.

        ``lon`` and ``lat`` are in degrees. A closed ring may repeat its first vertex.
        """
        lon = np.asarray(lon, dtype=np.float64).ravel()
        lat = np.asarray(lat, dtype=np.float64).ravel()
        if lon.shape != lat.shape:
            raise InvalidGeometryError(
                f"lon and lat have different lengths ({lon.size} and {lat.size})"
            )
        pts = np.column_stack([lon, lat])
        parts = _gj.Parts()
        if closed:
            parts.polygons.append([pts])
            parts.polygon_labels.append("array polygon")
        else:
            parts.lines.append(pts)
            parts.line_labels.append("array line")
        return _from_parts(parts)

    # ------------------------------------------------------------------ derived data
    @property
    def n_groups(self) -> int:
        """Number of region components (:attr:`ring_groups`)."""
        return int(self.ring_groups.max()) + 1 if len(self.ring_groups) else 0

    @property
    def n_vertices(self) -> int:
        """Number of vertices of the rings and lines."""
        return sum(len(r) for r in self.rings) + sum(len(ln) for ln in self.lines)

    def edges(self) -> Edges:
        """Return the flat edge table (cached)."""
        got = self.derived.edges  # the hot path: one read, no call
        return got if got is not None else self.derived.once("edges", self._make_edges)

    def _make_edges(self) -> Edges:
        a, b, bd, g = [], [], [], []
        for ring, seams, grp in zip(self.rings, self.ring_seams, self.ring_groups):
            a.append(ring)
            b.append(np.roll(ring, -1, axis=0))
            bd.append(~seams)
            g.append(np.full(len(ring), grp))
        for line in self.lines:
            if len(line) == 1:
                a.append(line)
                b.append(line)
            else:
                a.append(line[:-1])
                b.append(line[1:])
            bd.append(np.ones(max(len(line) - 1, 1), dtype=bool))
            g.append(np.full(max(len(line) - 1, 1), -1))
        return Edges(
            np.concatenate(a),
            np.concatenate(b),
            np.concatenate(bd),
            np.concatenate(g).astype(np.int64),
        )

    def arcs(self) -> CurveArcs:
        """Return the edges as arcs with their normals, bounding caps and cap trees.

        The one edge index of the shape (:class:`gloffset.edges.CurveArcs`, made once).
        """
        from .edges import CurveArcs

        return CurveArcs.from_shape(self)

    def reference_points(self) -> tuple[np.ndarray, np.ndarray]:
        """Two points and whether each lies inside each region component.

        Returns ``(refs, status)`` with ``refs`` (2, 3) and ``status`` (2, n_groups)
        bool. The status is found once by walking from a point known to be just
        inside each component (left of one of its boundary edges, closer to that
        edge than to any other) to the reference point, counting crossings.
        """
        got = self.derived.ref_status  # the hot path: one read, no call
        if got is None:
            got = self.derived.once("ref_status", lambda: _reference_status(self))
        return _REF, got

    def overlapping_components(self) -> np.ndarray:
        """Pairs of region components that overlap, as an (k, 2) int array (cached).

        A pair overlaps when an edge of one properly crosses an edge of the other
        (edges that only touch or coincide to 1e-13 rad, as neighbouring countries'
        borders do, do not count), or when a vertex of one lies strictly inside the
        other (nesting). Every operation unites components; fast paths that count
        crossings over all rings at once use this to know where that differs.
        """
        return self.derived.once("overlap", lambda: _overlapping_components(self))

    def component_caps(self) -> tuple[np.ndarray, np.ndarray]:
        """Return a bounding cap (centre, radius in radians) of each region component."""
        e = self.edges()
        centres = np.zeros((self.n_groups, 3))
        radii = np.zeros(self.n_groups)
        for k in range(self.n_groups):
            sel = e.group == k
            c = normalize(e.a[sel].sum(axis=0))
            if not np.any(c):
                radii[k] = np.pi
                continue
            mid, half = arc_cap(e.a[sel], e.b[sel])
            r = angle(c, mid) + half
            centres[k], radii[k] = c, min(pad(float(r.max()), abs_=1e-12), np.pi)
        return centres, radii

    # ------------------------------------------------------------------ output
    def to_geojson(self, *, digits: int | None = None) -> dict:
        """Return the shape as an RFC 7946 GeoJSON Feature.

        A shape read from GeoJSON (or arrays) writes back its polygons, lines and
        points as they were given (rings closed, exterior rings counter-clockwise
        and holes clockwise), not the united region, so ``read(s.to_geojson())``
        gives the same shape. A shape made otherwise (a multiresolution level)
        writes its region's rings, cut at the antimeridian.
        """
        if self.source is not None:
            return {
                "type": "Feature",
                "properties": {},
                "geometry": _source_geometry(self.source, digits),
            }
        geoms = []
        if self.rings:
            for grp in range(self.n_groups):
                rings = [
                    r for r, s, g in zip(self.rings, self.ring_seams, self.ring_groups) if g == grp
                ]
                north = self._inside_group(np.array([[0.0, 0.0, 1.0]]), grp)[0]
                geoms.append(_gj.rings_to_geometry(rings, bool(north), digits))
        lines = [ln for ln in self.lines if len(ln) > 1]
        if lines:
            geoms.append(_gj.lines_to_geometry(lines, digits))
        points = [ln[0] for ln in self.lines if len(ln) == 1]
        if points:
            from .geometry.sphere import xyz_to_lonlat

            lon, lat = xyz_to_lonlat(np.asarray(points))
            geoms.append(
                {"type": "MultiPoint", "coordinates": np.column_stack([lon, lat]).tolist()}
            )
        geom = _merge_geometries(geoms)
        return {"type": "Feature", "properties": {}, "geometry": geom}

    def _inside_group(self, p: np.ndarray, grp: int) -> np.ndarray:
        from .geometry.crossings import inside

        return inside(self, p, groups=[grp])

    def __repr__(self) -> str:
        return (
            f"Shape({len(self.rings)} rings in {self.n_groups} regions, "
            f"{len(self.lines)} lines/points, {self.n_vertices} vertices)"
        )


def read(source, *, layer=None, where: str | None = None, densify=None) -> Shape:
    """Read geometry into a :class:`Shape`.

    Parameters
    ----------
    source
        A path to a GeoJSON file or another vector file (Shapefile, GeoPackage,
        FlatGeobuf, GeoParquet...: the ``files`` extra), ``"-"`` for stdin, a GeoJSON
        string or dict (Geometry, Feature or FeatureCollection), an object with
        ``__geo_interface__`` (shapely), an existing :class:`Shape`, or an (n, 2)
        array of lon/lat in degrees (a polygon ring when its first and last rows
        are equal, else a line). A file in another CRS is transformed to lon/lat.
    layer : str or int, optional
        The layer of a vector file with several.
    where : str, optional
        An attribute filter (OGR SQL) selecting features of a vector file, e.g.
        ``"continent = 'Africa'"``.
    densify : float or str, optional
        The tolerance to which the edges of a file in a projected CRS are followed:
        their straight lines in the projection get points until the great circles
        between them are within it (metres, or a distance with its unit such as
        ``"0.1m"``), at least 1 mm. Default: 1 m or a hundredth of the edge, whichever
        is smaller. Lon/lat edges are great circles already and get no points; the
        value is checked for every input.

    Examples
    --------
    >>> s = read({"type": "LineString", "coordinates": [[0, 0], [10, 0]]})
    >>> len(s.lines), len(s.lines[0])
    (1, 2)
    """
    _densify_tolerance(densify)  # checked whatever the input
    if isinstance(source, Shape) and layer is None and where is None:
        return source
    if isinstance(source, np.ndarray):
        if source.ndim != 2 or source.shape[1] != 2:
            raise InputFormatError(f"a lon/lat array must have shape (n, 2), got {source.shape}")
        closed = len(source) >= 4 and np.array_equal(source[0], source[-1])
        return Shape.from_lonlat(source[:, 0], source[:, 1], closed=closed)
    return Shape.from_geojson(source, layer=layer, where=where, densify=densify)


# ---------------------------------------------------------------------- building


def _from_parts(parts: _gj.Parts) -> Shape:
    if len(parts) == 0:
        raise InvalidGeometryError("empty geometry: no polygon, line or point to offset")
    comps: list[int] = []
    holes: list[bool] = []
    labels: list[str] = []
    src = _gj.Parts()
    all_ll = []
    for c, (poly, plabel) in enumerate(zip(parts.polygons, parts.polygon_labels)):
        for k, ll in enumerate(poly):
            all_ll.append(ll)
            labels.append(f"{plabel} ring {k}")
            comps.append(c)
            holes.append(k > 0)
    # each ring checked, made unit vectors and oriented: exterior CCW, holes CW
    rings, seams, closed = prepare_rings(all_ll, labels, [not h for h in holes])
    at = 0
    for poly, plabel in zip(parts.polygons, parts.polygon_labels):
        src.polygons.append(closed[at : at + len(poly)])
        src.polygon_labels.append(plabel)
        at += len(poly)
    region = unite(rings, seams, comps, holes, labels)
    if rings and not region.rings:
        raise InvalidGeometryError(
            f"{parts.polygon_labels[0]}: the polygons leave no boundary: they cover the whole "
            "sphere (a ring along +-180 deg and the poles, with no hole) or enclose no area; "
            "a region needs a boundary to measure distances from"
        )
    lines, line_labels = [], []
    for ll, label in zip(parts.lines, parts.line_labels):
        v, idx = validate(ll, label, min_points=2)
        lines.append(v)
        line_labels.append(label)
        src.lines.append(ll[idx])
        src.line_labels.append(label)
    for ll, label in zip(parts.points, parts.point_labels):
        v, _ = validate(ll, label, min_points=1)
        lines.append(v[:1])
        line_labels.append(label)
        src.points.append(ll[:1])
        src.point_labels.append(label)
    return Shape(
        region.rings,
        region.seams,
        region.groups,
        region.holes,
        lines,
        region.labels + line_labels,
        source=src,
    )


def _source_geometry(parts: _gj.Parts, digits: int | None) -> dict:
    """GeoJSON geometry of validated lon/lat parts (see :meth:`Shape.to_geojson`)."""

    def rnd(a):
        return (np.round(a, digits) if digits is not None else a).tolist()

    geoms = []
    if parts.polygons:
        geoms.append(
            {"type": "MultiPolygon", "coordinates": [[rnd(r) for r in p] for p in parts.polygons]}
        )
    if parts.lines:
        geoms.append({"type": "MultiLineString", "coordinates": [rnd(ln) for ln in parts.lines]})
    if parts.points:
        geoms.append({"type": "MultiPoint", "coordinates": [rnd(p[0]) for p in parts.points]})
    return _merge_geometries(geoms)


def _reference_status(shape: Shape) -> np.ndarray:
    """(2, n_groups) bool: whether each reference point lies inside each component.

    Per component, from a point just inside it (:func:`_inner_points`) to each reference
    point (through the other one when the two are far apart), by the parity of the
    crossings with the component's own edges; all components in a fixed number of
    numpy calls (one crossing test per edge and route).
    """
    e = shape.edges()
    status = np.zeros((2, shape.n_groups), dtype=bool)
    if shape.n_groups == 0:
        return status
    order = np.argsort(e.group, kind="stable")
    order = order[e.group[order] >= 0]
    grp = e.group[order]
    inner = _inner_points(shape, order, grp)
    a, b = e.a[order], e.b[order]
    ab = robust_cross(a, b)

    def parity(p, r):
        """Per component: parity of the crossings of its arc ``p[g] -> r`` (or ``r[g]``)."""
        p = np.broadcast_to(p, inner.shape)
        q = np.broadcast_to(r, inner.shape)
        hit = arcs_cross(p[grp], q[grp], a, b, ab)
        return np.bincount(grp[hit], minlength=shape.n_groups) % 2 == 1

    for k in range(2):
        ref, via = _REF[k], _REF[1 - k]
        near = dot(inner, ref) > -0.5
        par = np.where(near, parity(inner, ref), parity(inner, via) ^ parity(via[None], ref))
        status[k] = ~par
    return status


def _inner_points(shape: Shape, order: np.ndarray, grp: np.ndarray) -> np.ndarray:
    """(n_groups, 3): per component a point just left of a boundary edge, hence inside it.

    ``order``: the ring edges sorted by component (stably), ``grp`` their components.
    The edge is the component's longest boundary edge (any edge where it has none: the
    most robust), the point at ``eps`` from its middle, closer to it than to any other
    edge of the component (neighbours sharing a border are other components and do
    not count).
    """
    e = shape.edges()
    n_groups = shape.n_groups
    starts = np.searchsorted(grp, np.arange(n_groups))
    if np.any(np.diff(np.r_[starts, len(grp)]) == 0):
        raise InvalidGeometryError("a region component has no edges")
    a, b = e.a[order], e.b[order]
    bd = e.boundary[order]
    has_bd = np.bincount(grp[bd], minlength=n_groups) > 0
    length = angle(a, b)
    score = np.where(bd | ~has_bd[grp], length, -1.0)
    best = np.maximum.reduceat(score, starts)
    pos = np.arange(len(grp))
    pick = np.minimum.reduceat(np.where(score == best[grp], pos, len(grp)), starts)
    m = normalize(a[pick] + b[pick])
    n = normalize(robust_cross(a[pick], b[pick]))
    dist = arc_distance(m[grp], a, b)
    dist[pick] = np.inf
    dmin = np.minimum.reduceat(dist, starts)
    dmin[np.isinf(dmin)] = 1.0
    eps = np.minimum(np.minimum(1e-3, 0.25 * dmin), 0.25 * length[pick])
    bad = np.flatnonzero(eps <= 1e-13)
    if len(bad):
        g = int(bad[0])
        raise InvalidGeometryError(
            f"{shape.labels[int(np.flatnonzero(shape.ring_groups == g)[0])]}: ring is degenerate "
            "(its edges overlap), so its inside is undefined"
        )
    return normalize(np.cos(eps)[:, None] * m + np.sin(eps)[:, None] * n)


def _overlapping_components(shape: Shape) -> np.ndarray:
    pairs: set = set()
    if shape.n_groups < 2:
        return np.zeros((0, 2), dtype=np.int64)
    from .edges import component_status
    from .geometry.sphere import orient

    arcs = shape.arcs()
    ring = arcs.ring
    a, b, g = arcs.a[ring], arcs.b[ring], arcs.group[ring]
    i, j = arcs.ring_tree.self_pairs()
    other = g[i] != g[j]
    i, j = i[other], j[other]
    if len(i):
        # a proper crossing: each arc strictly separates the other's ends, on the
        # same side of the sphere (the rule of gloffset.geometry.sphere.arcs_cross, strict)
        # (sides measured as angles to the great circle; within 1e-13 rad counts as
        # touching, so borders shared up to rounding are not overlaps)
        ni = np.linalg.norm(np.cross(a[i], b[i]), axis=1)
        nj = np.linalg.norm(np.cross(a[j], b[j]), axis=1)
        o1, o2 = orient(a[i], b[i], a[j]) / ni, orient(a[i], b[i], b[j]) / ni
        o3, o4 = orient(a[j], b[j], a[i]) / nj, orient(a[j], b[j], b[i]) / nj
        clear = np.minimum.reduce([np.abs(o1), np.abs(o2), np.abs(o3), np.abs(o4)]) > 1e-13
        hit = clear & (o1 * o2 < 0) & (o3 * o4 < 0) & ((o3 > 0) == (o2 > 0))
        pairs.update(zip(g[i[hit]].tolist(), g[j[hit]].tolist()))
    # nesting: a vertex of one component strictly inside another
    first = np.array([np.flatnonzero(g == k)[0] for k in range(shape.n_groups)])
    p = a[first]
    status = np.unpackbits(component_status(shape, arcs, p), axis=1, bitorder="little")[
        :, : shape.n_groups
    ].astype(bool)
    status[np.arange(shape.n_groups), np.arange(shape.n_groups)] = False
    for k in np.flatnonzero(status.any(axis=1)):
        for m in np.flatnonzero(status[k]):
            sel = g == m
            if arc_distance(p[k], a[sel], b[sel]).min() > 1e-12:
                pairs.add((int(k), int(m)))
    out = np.array(sorted({(min(x, y), max(x, y)) for x, y in pairs}), dtype=np.int64)
    return out.reshape(-1, 2)


def _merge_geometries(geoms: list[dict]) -> dict:
    if len(geoms) == 1:
        return geoms[0]
    polys = []
    others = []
    for g in geoms:
        if g["type"] == "Polygon":
            polys.append(g["coordinates"])
        elif g["type"] == "MultiPolygon":
            polys.extend(g["coordinates"])
        else:
            others.append(g)
    out = []
    if polys:
        out.append({"type": "MultiPolygon", "coordinates": polys})
    out.extend(others)
    return out[0] if len(out) == 1 else {"type": "GeometryCollection", "geometries": out}
