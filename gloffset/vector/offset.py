"""Vector offsets made of small-circle arcs (paper Sec. 4.1, Eq. 1-4).

Each ring and line of a shape becomes a cycle of small-circle arcs at signed angular
distance ``d`` (Eq. 1-4, built by :mod:`gloffset.vector.arcrings`).

Rings keep their interior on the left, so ``d > 0`` goes outward (to the right) and
``d < 0`` inward. Lines get round caps; an isolated point gives a circle.

Raw and resolved. :class:`Offset` holds the *raw* offset of the paper's Sec. 4.1:
every point of it lies at exactly ``|d|`` from its generating vertex or edge, but
concave corners produce loops, and the offsets of separate parts (or of the two
sides of a line) overlap. :meth:`Offset.resolve` removes them (Sec. 4.4, see
:mod:`gloffset.vector.selfintersect`) and returns the true boundary of the offset region
as valid polygons of small-circle arcs; :meth:`Offset.to_geojson` writes that by
default (``raw=True`` writes the raw rings). A seam that has no partner across the
antimeridian (see :mod:`gloffset.shape`) is offset like a boundary edge here,
although the reference and raster paths ignore it.
"""

from __future__ import annotations

import numpy as np

from ..shape import Shape, read
from ..units import EARTH_RADIUS, VECTOR_LIMIT, check_radius, offset_angle
from .arcrings import DEFAULT_TOLERANCE, ArcRings, OffsetRing, line_arcs, ring_arcs, sample_rings

__all__ = ["Offset", "offset"]


class Offset(ArcRings):
    """The raw offset of a shape at a distance (paper Sec. 4.1).

    Attributes
    ----------
    distance : float
        Signed angular distance in radians.
    given : float, str or None
        The distance as given to :func:`offset` (``"127km"``, or a number in the units
        of ``radius``); None when the class is made directly (then the angle is named).
    radius : float
        The sphere radius that ``given`` is measured with (1.0: an angle).
    rings : list of OffsetRing
        One closed cycle of arcs per ring of the shape (``d != 0``), one per line
        (both sides with round caps, ``d > 0``) and a circle per isolated point.
    """

    given = None  # subclasses made without them (multiresolution levels): the angle
    radius = 1.0

    def __init__(self, shape: Shape, d: float, *, given=None, radius: float = 1.0):
        self.shape = shape
        self.distance = d
        self.given = given
        self.radius = radius
        self.rings: list[OffsetRing] = []
        for ring in shape.rings:
            self.rings.append(ring_arcs(ring, d))
        if d > 0.0:
            for line in shape.lines:
                self.rings.append(line_arcs(line, d))

    def __repr__(self) -> str:
        """Say what the offset holds, not ``<... object at 0x...>``.

        The distance (as given and as an angle), the raw rings and arcs, and whether
        :meth:`resolve` has been called (then the ``ResolvedOffset`` of each method
        called), e.g. ``Offset('127km' = 0.019934 rad: 51 rings, 14,913 arcs, raw; not
        resolved)``.
        """
        d = f"{self.distance:.6g} rad"
        if self.given is not None:
            d = f"{self.given!r} = {d}" if isinstance(self.given, str) else f"{self.given:g} = {d}"
        n, arcs = len(self.rings), sum(len(r.centers) for r in self.rings)
        done = self.__dict__.get("_resolved", {})
        state = ", ".join(repr(res) for res in done.values())
        state = f"resolved: {state}" if state else "not resolved"
        rings = f"{n:,} ring{'' if n == 1 else 's'}, {arcs:,} arcs"
        return f"{type(self).__name__}({d}: {rings}, raw; {state})"

    def sample(self, tolerance: float = DEFAULT_TOLERANCE) -> list[np.ndarray]:
        """Densified raw rings: points on the arcs, no arc deviating more than ``tolerance``.

        ``tolerance`` is an angle (radians): the great-circle segment between two
        consecutive points stays within it of the true small-circle arc.
        """
        return sample_rings(self.rings, tolerance)

    def resolve(self, method: str = "general"):
        """Return the offset region's boundary without self-intersections (paper Sec. 4.4).

        Parameters
        ----------
        method : {"general", "paper"}
            ``"general"`` (default): exact, united over all parts, with holes and
            several components (:mod:`gloffset.vector.arrangement`). ``"paper"``:
            Algorithm 1 as published, ring by ring (:mod:`gloffset.vector.paper`).

        Returns
        -------
        gloffset.vector.resolved.ResolvedOffset
            Rings of small-circle arcs (Q/R per ring), exterior/hole flags and
            polygons; cached per method.

        Notes
        -----
        Accuracy (``"general"``): every point of the result lies at ``|d|`` from
        the curves to 1e-12 rad, rings do not cross, and the region equals the
        reference region (:func:`gloffset.index.contains`) except within ~1e-12 rad of
        its boundary.
        """
        from .selfintersect import resolve

        cache = self.__dict__.setdefault("_resolved", {})
        if method not in cache:
            cache[method] = resolve(self, method)
        return cache[method]

    def to_geojson(
        self,
        *,
        tolerance: float = DEFAULT_TOLERANCE,
        digits: int | None = None,
        raw: bool = False,
        method: str = "general",
    ) -> dict:
        """Return the offset region as an RFC 7946 Feature.

        ``offset_feature(self, ...)`` of :func:`gloffset.io.geojson.offset_feature`,
        where offsets are written.

        Rings are densified to ``tolerance`` (radians), cut at the antimeridian,
        exterior rings counter-clockwise. By default the resolved boundary
        (:meth:`resolve` with ``method``) is written: valid polygons with holes.
        ``raw=True`` writes the raw offset curves of Sec. 4.1 instead, as what they
        are: a MultiLineString of closed rings that may cross themselves and each
        other (property ``raw``: true).

        The properties are ``distance_m``, the distance in metres (in the units of
        :attr:`radius`), and ``distance``, the distance as given (:attr:`given`).
        """
        return self.writer.offset_feature(
            self, tolerance=tolerance, digits=digits, raw=raw, method=method
        )


def offset(shape, distance: float | str, *, radius: float = EARTH_RADIUS) -> Offset:
    """Offset a shape by ``distance`` (in the units of ``radius``) with small-circle arcs.

    Parameters
    ----------
    shape : Shape or anything :func:`gloffset.read` accepts
    distance : float or str
        In the units of ``radius``, or a string with a unit (``"127km"``,
        ``"0.02rad"``). Positive: outward from polygons and around lines and points.
        Negative: inward into polygons (lines and points then give nothing). Must be
        less than a quarter of a great circle in absolute value. Messages and the
        output's ``distance`` property quote it as given.
    radius : float
        Sphere radius (default :data:`gloffset.EARTH_RADIUS`, metres).

    Notes
    -----
    Accuracy: every point of every arc lies at ``|distance|`` from its generating
    vertex or edge to about 1e-15 rad (Eq. 1-4 are exact up to rounding). The raw
    offset is returned; :meth:`Offset.resolve` gives the boundary of the offset
    region without self-intersections (Sec. 4.4).

    Examples
    --------
    >>> import gloffset
    >>> line = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [10, 0]]})
    >>> off = gloffset.offset(line, 0.01, radius=1.0)
    >>> len(off.rings), off.centers[0].shape
    (1, (6, 3))
    """
    shape = read(shape)
    r = check_radius(radius)
    d = offset_angle(shape, distance, r, limit=VECTOR_LIMIT)
    return Offset(shape, d, given=distance, radius=r)
