"""Lon/lat rings and lines checked and made unit vectors, before a shape is built.

:func:`validate` rejects what has no great circle (coordinates out of range or not finite,
too few distinct points, consecutive antipodal points, each named by its vertex) and drops
repeated points; :func:`is_ccw` tells a ring's orientation (round a pole, through one, or
by its area on the sphere);
:func:`split_meridian_edges` keeps pole-to-pole edges along a meridian. Accuracy: points
closer than :data:`MIN_EDGE` count as repeated, coordinates within
:data:`gloffset.geometry.sphere.SEAM_EPS_DEG` of the seam or the poles as on them.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InvalidGeometryError
from .sphere import SEAM_EPS_DEG, angle, lonlat_to_xyz

__all__ = ["MIN_EDGE", "validate", "on_seam", "is_ccw", "split_meridian_edges"]

#: Angle (rad) below which consecutive points count as repeated (0.6 micrometres on
#: the Earth): shorter edges have no computable great circle in float64.
MIN_EDGE = 1e-13
#: Angle (rad) below which two consecutive input points count as antipodal.
ANTIPODAL_EPS = 1e-12


def validate(ll: np.ndarray, label: str, *, min_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Check lon/lat, convert to unit vectors and drop repeated consecutive points."""
    bad = ~np.isfinite(ll)
    if bad.any():
        i = int(np.flatnonzero(bad.any(axis=1))[0])
        raise InvalidGeometryError(
            f"{label} vertex {i}: coordinate is not finite ({ll[i].tolist()})"
        )
    badlat = np.abs(ll[:, 1]) > 90.0 + SEAM_EPS_DEG
    if badlat.any():
        i = int(np.flatnonzero(badlat)[0])
        raise InvalidGeometryError(
            f"{label} vertex {i}: latitude {float(ll[i, 1])!r} out of range [-90, 90]"
        )
    badlon = np.abs(ll[:, 0]) > 180.0 + SEAM_EPS_DEG
    if badlon.any():
        i = int(np.flatnonzero(badlon)[0])
        raise InvalidGeometryError(
            f"{label} vertex {i}: longitude {float(ll[i, 0])!r} out of range [-180, 180] "
            "(longitudes are not wrapped; subtract 360 from those above 180)"
        )
    v = lonlat_to_xyz(ll[:, 0], ll[:, 1])
    idx = np.arange(len(v))
    if len(v) > 1:
        keep = np.ones(len(v), dtype=bool)
        keep[1:] = angle(v[1:], v[:-1]) > MIN_EDGE
        v, idx = v[keep], idx[keep]
    if min_points == 3 and len(v) > 1 and angle(v[0], v[-1]) <= MIN_EDGE:
        v, idx = v[:-1], idx[:-1]
    if len(v) < min(min_points, 2) or (min_points == 3 and len(v) < 3):
        what = "a ring needs at least 3" if min_points == 3 else "a line needs at least 2"
        raise InvalidGeometryError(
            f"{label}: {what} distinct points, got {len(v)} (empty or degenerate geometry)"
        )
    nxt = np.roll(v, -1, axis=0) if min_points == 3 else v[1:]
    cur = v if min_points == 3 else v[:-1]
    if len(cur):
        anti = np.linalg.norm(cur + nxt, axis=1) < 2.0 * np.sin(ANTIPODAL_EPS / 2) + 1e-300
        if anti.any():
            i = int(np.flatnonzero(anti)[0])
            j = idx[(i + 1) % len(idx)]
            raise InvalidGeometryError(
                f"{label} vertices {idx[i]} and {j}: consecutive points are antipodal, so the "
                "great circle between them is undefined; add a point in between"
            )
    return v, idx


def on_seam(ll: np.ndarray) -> np.ndarray:
    return (np.abs(np.abs(ll[:, 0]) - 180.0) <= SEAM_EPS_DEG) | (
        np.abs(np.abs(ll[:, 1]) - 90.0) <= SEAM_EPS_DEG
    )


def is_ccw(ll: np.ndarray) -> bool:
    """Whether a lon/lat ring runs counter-clockwise, i.e. has its interior on the left.

    The rules, on the sphere (edges are great circles):

    - A ring that goes once round a pole without touching it (no vertex at a pole, no
      edge through one) is ambiguous in GeoJSON: it is taken to enclose the pole on
      its side of the equator, the side of the mean latitude of its vertices (summed
      exactly, so neither the start vertex nor the direction changes it), the north
      when that mean is exactly 0 (a ring along the equator). Going round is measured
      on the sphere: every edge turns by at most 180 deg of longitude, so vertices on
      +-180 deg do not cut the ring, nor does an edge along the antimeridian (it turns
      by 0).
    - A ring that touches a pole passes through it, not round it. An edge whose ends
      lie 180 deg of longitude apart (to :data:`SEAM_EPS_DEG`) passes through a pole
      (the north one when its ends' latitudes sum to more than 0, the south one when
      less; a sum of 0 is antipodal and refused before), and a lone vertex at a pole
      joins the meridians of its neighbours: at the pole the ring turns by whatever
      makes its whole turn 0. Edges drawn along a pole (from one pole vertex to
      another, as Natural Earth closes Antarctica along 90 S after cutting it at
      +-180 deg) turn by their longitudes as given.
    - A ring that does not go round a pole is then read by its area on the sphere
      (:func:`_sphere_area`, exact for great-circle edges, so a long edge that bows far
      from its straight lon/lat line, to or past a pole, is read as the sphere has it):
      the side that holds neither pole, or the side that the edges along a pole close.
    """
    lon, lat = ll[:, 0], ll[:, 1]
    jump = np.diff(lon, append=lon[0])  # edge i: vertex i -> i + 1
    step = jump - 360.0 * np.round(jump / 360.0)
    pole = np.abs(np.abs(lat) - 90.0) <= SEAM_EPS_DEG
    on_pole = bool(pole.any())
    through = np.abs(np.abs(step) - 180.0) <= SEAM_EPS_DEG
    if on_pole:
        nxt = _next(pole)
        along = pole & nxt
        step[along] = jump[along]
        through &= ~pole & ~nxt
    if through.any():
        step = _through_pole_steps(step, through)
    turn = float(np.sum(step))
    if on_pole and abs(turn) > 180.0:
        # a lone pole vertex: the edge leaving it turns the ring to its next neighbour
        lone = np.flatnonzero(pole & ~np.roll(pole, 1) & ~nxt)
        if len(lone):
            step[lone[0]] -= 360.0 * round(turn / 360.0)
            turn = float(np.sum(step))
    if abs(turn) < 180.0:
        return _sphere_area(step, lat, pole if on_pole else None) < 0.0
    if not on_pole and abs(abs(turn) - 360.0) < 1e-6:
        # once round a pole; eastward travel keeps the north on the left
        return (turn > 0) == (math.fsum(lat.tolist()) >= 0.0)
    return _lonlat_area(ll) > 0.0


def _next(a: np.ndarray) -> np.ndarray:
    """``a`` shifted by one, the first element last (``np.roll(a, -1)``, cheaper)."""
    return np.concatenate((a[1:], a[:1]))


def _through_pole_steps(step: np.ndarray, through: np.ndarray) -> np.ndarray:
    """The longitude turns of a ring's edges, those through a pole set to +-180 deg so
    that the ring's turn is 0 (it passes through the pole), or as near 0 as they can."""
    step = step.copy()
    n = int(through.sum())
    rest = float(np.sum(step[~through]))
    # k edges at +180 and n - k at -180 turn by 180 (2k - n): nearest to -rest
    k = int(np.clip(np.round((-rest / 180.0 + n) / 2.0), 0, n))
    step[through] = np.where(np.arange(n) < k, 180.0, -180.0)
    return step


def _sphere_area(step: np.ndarray, lat: np.ndarray, pole: np.ndarray | None) -> float:
    """The integral of sin(latitude) d(longitude) round a ring of great-circle edges.

    Edge by edge, the signed area between the edge and the equator, the edge turning by
    ``step`` deg of longitude (under 180, or through a pole at +-180):
    ``2 atan(tan(dlon/2) (t1 + t2) / (1 + t1 t2))`` with ``t = tan(lat/2)``; an edge
    with an end at a pole runs along the meridian of its other end and turns at the
    pole: its area is ``+-dlon``. For a ring whose turn is 0 it is minus the area on
    its left: negative when the ring runs counter-clockwise.
    """
    t = np.tan(np.radians(lat) / 2.0)
    t2 = _next(t)
    rad = np.radians(step)
    e = 2.0 * np.arctan2(np.tan(rad / 2.0) * (t + t2), 1.0 + t * t2)
    if pole is not None:  # ``pole``: the vertices at a pole
        at = pole | _next(pole)
        north = np.where(pole, lat, _next(lat)) > 0.0
        e[at] = np.where(north[at], rad[at], -rad[at])
    return math.fsum(e.tolist())


def _lonlat_area(ll: np.ndarray) -> float:
    """Twice the shoelace area in lon/lat, the ring's jumps over 180 deg unwrapped (those
    along the seam or a pole kept): the reading of the rings left (one with a vertex at
    a pole that turns round the pole all the same, one that goes round twice)."""
    lon, lat = ll[:, 0].copy(), ll[:, 1]
    jump = np.diff(np.append(lon, lon[0]))
    seam = on_seam(ll)
    big = (np.abs(jump) > 180.0) & ~(seam & np.roll(seam, -1))
    if big.any():
        lon[1:] -= 360.0 * np.cumsum(np.round(jump[:-1] / 360.0) * big[:-1])
    return float(np.sum(lon * np.roll(lat, -1) - np.roll(lon, -1) * lat))


def split_meridian_edges(ll: np.ndarray) -> np.ndarray:
    """Insert midpoints into ring edges that run along a meridian over 90 deg or more.

    Such an edge (a whole-world ring runs from pole to pole along +-180 deg) has
    ends that are antipodal or nearly so once the poles are snapped, so its great
    circle would be undefined; in lon/lat it is a meridian, and the midpoint keeps it
    one.
    """
    nxt = np.roll(ll, -1, axis=0)
    long_ = (np.abs(ll[:, 0] - nxt[:, 0]) <= SEAM_EPS_DEG) & (np.abs(ll[:, 1] - nxt[:, 1]) >= 90.0)
    if not long_.any():
        return ll
    out = []
    for k in range(len(ll)):
        out.append(ll[k])
        if long_[k]:
            for t in (0.25, 0.5, 0.75):
                out.append(ll[k] + t * (nxt[k] - ll[k]))
    return np.asarray(out)


def prepare_rings(
    rings: list[np.ndarray], labels: list[str], exterior: list[bool]
) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray]]:
    """Each lon/lat ring checked, made unit vectors and oriented, all rings at once.

    Per ring, what :func:`prepare_ring` gives (the same arrays, the same errors, raised
    for the first bad ring in order): its vertices, its seam edges and its lon/lat
    closed, with its interior on the left (``exterior[k]``: counter-clockwise, else
    clockwise). The rings are checked, converted and oriented in a few numpy passes over
    all their vertices; a ring that any check refuses or that needs more than that (an
    edge along a meridian over 90 deg, a vertex at a pole, an edge through one, a turn
    round a pole, an area too close to 0 for its sum's rounding) goes through
    :func:`prepare_ring`.
    """
    n = len(rings)
    if n == 0:
        return [], [], []
    # rings of fewer than 4 rows take prepare_ring (a square stands in for them here)
    tiny = np.array([r.ndim != 2 or r.shape[1] != 2 or len(r) < 4 for r in rings])
    stand = [_SQUARE if t else r for r, t in zip(rings, tiny.tolist())]
    sizes = np.fromiter((len(r) for r in stand), np.int64, n)
    ll = np.concatenate(stand).astype(np.float64, copy=False)
    ends = np.cumsum(sizes)
    starts = ends - sizes
    # the closing vertex, where the ring repeats its first
    closed = (ll[starts] == ll[ends - 1]).all(axis=1)
    keep = np.ones(len(ll), bool)
    keep[ends[closed] - 1] = False
    ll = ll[keep]
    sizes = sizes - closed
    ends = np.cumsum(sizes)
    starts = ends - sizes
    ring = np.repeat(np.arange(n), sizes)
    nxt = np.arange(len(ll)) + 1
    nxt[ends - 1] = starts
    slow = tiny.copy()
    lon, lat = ll[:, 0], ll[:, 1]
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(ll).all(axis=1)
        bad |= np.abs(lat) > 90.0 + SEAM_EPS_DEG
        bad |= np.abs(lon) > 180.0 + SEAM_EPS_DEG
        # edges along a meridian over 90 deg (split_meridian_edges)
        bad |= (np.abs(lon - lon[nxt]) <= SEAM_EPS_DEG) & (np.abs(lat - lat[nxt]) >= 90.0)
        slow[ring[bad]] = True
        v = lonlat_to_xyz(lon, lat)
        # repeated consecutive points dropped, then a last one equal to the first
        keep = np.ones(len(v), bool)
        keep[1:] = angle(v[1:], v[:-1]) > MIN_EDGE
        keep[starts] = True
        count = np.add.reduceat(keep.astype(np.int64), starts)
        pos = np.arange(len(v))
        last = np.maximum.reduceat(np.where(keep, pos, -1), starts)
        drop = (count > 1) & (angle(v[starts], v[last]) <= MIN_EDGE)
        keep[last[drop]] = False
        count -= drop
        slow |= count < 3
    k = np.flatnonzero(keep)
    v, ll, ring = v[k], ll[k], ring[k]
    ends = np.cumsum(count)
    starts = ends - count
    nxt = np.arange(len(v)) + 1
    nxt[ends - 1] = starts
    with np.errstate(invalid="ignore"):
        anti = np.linalg.norm(v + v[nxt], axis=1) < 2.0 * np.sin(ANTIPODAL_EPS / 2) + 1e-300
    slow[ring[anti]] = True
    with np.errstate(invalid="ignore"):
        ccw = _ccw_many(ll, nxt, starts)  # None where the ring takes is_ccw itself
    # every ring in its final order: reversed where its orientation is not the one asked
    s_, e_ = starts.tolist(), ends.tolist()
    flip = np.zeros(n, bool)
    for r in np.flatnonzero(~slow).tolist():
        c = ccw[r]
        if c is None:
            c = is_ccw(ll[s_[r] : e_[r]])
        flip[r] = c != exterior[r]
    pos = np.arange(len(v))
    rev = flip[ring]
    base = np.repeat(starts + ends - 1, count)
    order = np.where(rev, base - pos, pos)
    v, ll = v[order], ll[order]
    on = on_seam(ll)
    seam = on & on[nxt]
    # each ring's lon/lat closed: its first vertex again after its last
    first_again = np.insert(np.arange(len(ll)), ends, starts)
    ll_closed = ll[first_again]
    vs = [v[a:b] for a, b in zip(s_, e_)]
    seams = [seam[a:b] for a, b in zip(s_, e_)]
    lls = [ll_closed[a + r : b + r + 1] for r, (a, b) in enumerate(zip(s_, e_))]
    for r in np.flatnonzero(slow).tolist():
        vs[r], seams[r], lls[r] = prepare_ring(rings[r], labels[r], exterior[r])
    return vs, seams, lls


_SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


def prepare_ring(
    ll: np.ndarray, label: str, exterior: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One lon/lat ring (closed or not) checked, made unit vectors and oriented.

    Returns its vertices (unit vectors, repeated points dropped), its seam edges and its
    lon/lat closed, interior on the left: counter-clockwise when ``exterior``, else
    clockwise (:func:`is_ccw`). Errors as :func:`validate`'s, naming ``label``.
    """
    if len(ll) > 1 and np.array_equal(ll[0], ll[-1]):
        ll = ll[:-1]
    ll = split_meridian_edges(ll)
    v, idx = validate(ll, label, min_points=3)
    ll_v = ll[idx]
    on = on_seam(ll_v)
    seam = on & np.roll(on, -1)
    if is_ccw(ll_v) != exterior:  # exterior CCW, holes CW
        v, seam, ll_v = v[::-1].copy(), np.roll(seam[::-1], -1), ll_v[::-1]
    return v, seam, np.vstack([ll_v, ll_v[:1]])


def _ccw_many(ll: np.ndarray, nxt: np.ndarray, starts: np.ndarray) -> list:
    """:func:`is_ccw` of the rings ``ll[starts[r]:starts[r + 1]]`` (``nxt``: each vertex's
    successor in its ring) where its answer is the sign of the ring's area with no pole
    on it or round it; None for the others (a vertex at a pole, an edge through one, a
    turn of 90 deg or more, an area whose sign the rounding of its sum leaves open)."""
    lon, lat = ll[:, 0], ll[:, 1]
    jump = lon[nxt] - lon
    step = jump - 360.0 * np.round(jump / 360.0)
    pole = np.abs(np.abs(lat) - 90.0) <= SEAM_EPS_DEG
    through = np.abs(np.abs(step) - 180.0) <= SEAM_EPS_DEG
    odd = np.add.reduceat((pole | through).astype(np.int64), starts) > 0
    turn = np.add.reduceat(step, starts)
    # the terms of _sphere_area, with no pole
    t = np.tan(np.radians(lat) / 2.0)
    rad = np.radians(step)
    e = 2.0 * np.arctan2(np.tan(rad / 2.0) * (t + t[nxt]), 1.0 + t * t[nxt])
    total = np.add.reduceat(e, starts)
    size = np.diff(np.append(starts, len(ll)))
    # a sum of m terms in order is within (m - 1) u sum|e| of the exact one (fsum's)
    err = 4.0 * size * np.finfo(np.float64).eps * np.add.reduceat(np.abs(e), starts)
    sure = (~odd & (np.abs(turn) < 90.0) & (np.abs(total) > err)).tolist()
    return [c if s else None for c, s in zip((total < 0.0).tolist(), sure)]
