"""The result of self-intersection removal: :class:`ResolvedOffset` (paper Sec. 4.4).

The boundary of the offset region as closed rings of small-circle arcs (the Q/R of
Eq. 1-4, pieces of the raw offset of Sec. 4.1), sorted into exteriors and holes and
grouped into polygons (:mod:`gloffset.vector.rings`). What the region offers besides its
rings lives here too: membership of points (crossing parity against the rings), its
area (Gauss-Bonnet on the arcs) and densified rings, which
:func:`gloffset.io.geojson.region_feature` writes as GeoJSON. Both methods of
:mod:`gloffset.vector.selfintersect` (:mod:`~gloffset.vector.paper`,
:mod:`~gloffset.vector.arrangement`) return one, built with
:meth:`ResolvedOffset.from_rings`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..memo import once_attr
from .arcrings import DEFAULT_TOLERANCE, ArcRings, sample_rings
from .rings import RingParity, holes_and_polygons, left_areas, ring_table

__all__ = ["ResolvedOffset"]


@dataclass
class ResolvedOffset(ArcRings):
    """The boundary of an offset region: closed rings of small-circle arcs.

    Attributes
    ----------
    distance : float
        Signed angular distance (radians).
    method : str
        ``"general"`` or ``"paper"``.
    rings : list of :class:`gloffset.vector.arcrings.OffsetRing`
        Closed rings with the region on their left; arc ``k`` of a ring runs from
        ``junctions[k-1]`` to ``junctions[k]`` about ``centers[k]`` (Eq. 1), and
        ``kind``/``sources`` name the vertex or edge it keeps its distance from.
    holes : (len(rings),) bool
        True for rings that bound a hole (seen from a point outside the region); found
        on first use (the rings alone need none of it).
    polygons : list of (int, list of int)
        Exterior ring index and the indices of its holes (found with ``holes``).
    unlinked : int
        Pieces of boundary that could not be closed into rings (0 unless arcs are
        tangent to within ~1e-12 rad); always 0 for ``method="paper"``.

    Notes
    -----
    Accuracy contract (``method="general"``): every point of every ring lies at
    ``|distance|`` from the curves to 1e-12 rad (the arcs are pieces of raw offset
    arcs, exact to ~1e-15, whose end points are intersections computed to their
    stated error; measured: below 1e-15 rad on all test data); no point of the
    curves is closer than ``|distance| - 1e-12`` to a ring; rings do not cross
    each other or themselves (they may touch at single points); and the region
    they bound equals the reference region (:func:`gloffset.index.contains`) except
    within 1e-9 rad of its boundary: gaps and parts narrower than that are closed
    or dropped rather than kept as slivers. ``method="paper"`` gives what
    Algorithm 1 gives: exact on the loops it handles, no union, no holes.
    """

    distance: float
    method: str
    rings: list
    given_holes: np.ndarray | None = field(default=None, repr=False)
    given_polygons: list | None = field(default=None, repr=False)
    unlinked: int = 0
    shape: object = None

    @classmethod
    def from_rings(cls, distance, method, rings, shape, unlinked: int = 0) -> ResolvedOffset:
        """Return the region bounded by ``rings`` (region on their left).

        Its holes and polygons are found on first use, by
        :func:`gloffset.vector.rings.holes_and_polygons`, whose parity it keeps.
        """
        return cls(distance, method, rings, None, None, unlinked, shape)

    @property
    def holes(self) -> np.ndarray:
        """Whether each ring bounds a hole (see the class's attributes)."""
        return self._classes()[0]

    @property
    def polygons(self) -> list:
        """Exterior ring index and the indices of its holes, per polygon."""
        return self._classes()[1]

    def _classes(self) -> tuple:
        if self.given_holes is not None and self.given_polygons is not None:
            return self.given_holes, self.given_polygons

        def build():
            parity = self._parity_index()
            holes, polygons, _ = holes_and_polygons(self.rings, self.shape, self.distance, parity)
            return holes, polygons

        return once_attr(self, "_classified", build)

    def sample(self, tolerance: float = DEFAULT_TOLERANCE) -> list[np.ndarray]:
        """Densified rings (see :meth:`gloffset.Offset.sample`)."""
        return sample_rings(self.rings, tolerance)

    def contains_xyz(self, p) -> np.ndarray:
        """Whether unit vectors ``p`` (n, 3) lie in the region the rings bound.

        Crossing parity of short great-circle arcs against the rings' small-circle
        arcs: exact for points farther than ~1e-15 rad from every ring.
        """
        p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
        return self._parity_index().contains(p)

    def area(self) -> float:
        """Area of the region in steradians (Gauss-Bonnet on the arcs; ~1e-13 absolute)."""
        if not self.rings:
            return 4.0 * np.pi if self._parity_index().outside_status else 0.0
        arcs, ring_id, first = ring_table(self.rings)
        left = left_areas(arcs, ring_id, first)
        # crossing ring k from the outside point X into its left side adds 1 to the
        # region's indicator, so 1_R(p) = 1_R(X) + sum_k (1[p left of k] - 1[X left of k]),
        # and X lies on the left of the holes: the area is the sum of the left areas less
        # 4 pi per hole, wherever X lies (a hole may have no exterior around it)
        parity = self._parity_index()
        total = float(np.sum(left)) - 4.0 * np.pi * int(np.count_nonzero(self.holes))
        return total + (4.0 * np.pi if parity.outside_status else 0.0)

    def to_geojson(
        self,
        *,
        tolerance: float = DEFAULT_TOLERANCE,
        digits: int | None = None,
        properties: dict | None = None,
    ) -> dict:
        """Return the region as an RFC 7946 Feature.

        ``region_feature(self, ...)`` of :func:`gloffset.io.geojson.region_feature`,
        where offsets are written.

        Arcs are densified so that no written edge strays more than ``tolerance``
        (radians) from its arc; rings are cut at the antimeridian, exterior rings
        run counter-clockwise and holes clockwise. ``properties`` default to
        ``distance_m`` and ``distance``, both the angle (a resolved offset lies on the
        unit sphere; :meth:`gloffset.Offset.to_geojson` gives its own radius's).
        """
        return self.writer.region_feature(
            self, tolerance=tolerance, digits=digits, properties=properties
        )

    def _parity_index(self) -> RingParity:
        """Crossing parity against the rings (built on first use)."""
        return once_attr(self, "_parity", lambda: RingParity(self.rings, self.shape, self.distance))

    def __repr__(self) -> str:
        nh = int(np.count_nonzero(self.holes))
        return (
            f"ResolvedOffset({len(self.polygons)} polygons, {len(self.rings) - nh} exteriors, "
            f"{nh} holes, {sum(len(r.centers) for r in self.rings)} arcs, method={self.method!r})"
        )
