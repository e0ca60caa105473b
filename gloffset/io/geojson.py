"""GeoJSON in and out.

Reading turns GeoJSON (a path, ``-`` for stdin, a JSON string, a dict, or any object
with ``__geo_interface__``) into plain lon/lat parts: polygons (lists of rings),
lines and points, each labelled for error messages. Validation and the move to
unit vectors happen in :mod:`gloffset.shape`.

Writing takes rings of unit vectors whose interior lies on their left (the
orientation gloffset keeps everywhere) and produces RFC 7946 geometry: rings cut
at the antimeridian, regions around a pole closed along the +-90 deg edges,
exterior rings counter-clockwise and holes clockwise in lon/lat. The offsets
(:func:`offset_feature`, :func:`region_feature`, :func:`disc_geometry`) are written
here: :mod:`gloffset.vector` makes rings and knows no file format.
"""

from __future__ import annotations

import contextlib
import gc
import itertools
import json
import numbers
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputFormatError, OptionError
from ..geometry.sphere import normalize, xyz_to_lonlat
from ..units import distance_properties

__all__ = [
    "Parts",
    "load",
    "parse",
    "rings_to_geometry",
    "lines_to_geometry",
    "region_feature",
    "offset_feature",
    "disc_geometry",
]


@dataclass
class Parts:
    """Lon/lat parts read from GeoJSON, with a label per part for error messages."""

    polygons: list[list[np.ndarray]] = field(default_factory=list)
    polygon_labels: list[str] = field(default_factory=list)
    lines: list[np.ndarray] = field(default_factory=list)
    line_labels: list[str] = field(default_factory=list)
    points: list[np.ndarray] = field(default_factory=list)
    point_labels: list[str] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.polygons) + len(self.lines) + len(self.points)


def load(source) -> dict:
    """Read a GeoJSON object from a path, ``-`` (stdin), a JSON string or a dict."""
    if isinstance(source, dict):
        return source
    if hasattr(source, "__geo_interface__"):
        gi = source.__geo_interface__
        if isinstance(gi, dict):
            return gi
        try:
            return dict(gi)
        except (TypeError, ValueError):
            raise InputFormatError(
                f"{type(source).__name__}.__geo_interface__ is not a mapping"
            ) from None
    if hasattr(source, "read"):
        text = source.read()
        where = getattr(source, "name", "stream")
    elif isinstance(source, (str, os.PathLike)):
        s = os.fspath(source)
        if s == "-":
            text, where = sys.stdin.read(), "<stdin>"
        elif isinstance(source, str) and source.lstrip()[:1] in ("{", "["):
            text, where = source, "<string>"
        else:
            text, where = _read_file(s), s
    else:
        raise InputFormatError(
            f"cannot read geometry from {type(source).__name__!s}: give a path, '-', a GeoJSON "
            "dict or string, an object with __geo_interface__, or use Shape.from_lonlat"
        )
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise InputFormatError(f"{where} is not UTF-8 text: {exc}") from None
    if not isinstance(text, str):
        raise InputFormatError(f"{where} gave {type(text).__name__}, not text")
    return _loads(text, where)


def _read_file(s: str) -> str:
    try:
        path = Path(s)
        if not path.exists():
            raise InputFormatError(f"no such file: {s!r}")
        if path.is_dir():
            raise InputFormatError(f"{s!r} is a directory, not a GeoJSON file")
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        if isinstance(exc, InputFormatError):
            raise
        raise InputFormatError(f"cannot read {s!r}: {exc}") from None


def _loads(text: str, where: str):
    long = []  # the integer longer than Python converts, if json.loads met one

    def _int(number: str):
        try:
            return int(number)
        except ValueError:  # more digits than sys.get_int_max_str_digits()
            long.append(number)
            raise

    try:
        with collector_paused():
            return json.loads(text, parse_int=_int)
    except json.JSONDecodeError as exc:
        raise InputFormatError(
            f"{where} is not valid JSON (line {exc.lineno}, column {exc.colno}): {exc.msg}"
        ) from None
    except ValueError:
        if not long:
            raise
        digits = long[0].lstrip("+-")
        at = text.find(digits)
        line = text.count("\n", 0, at) + 1
        col = at - text.rfind("\n", 0, at)
        raise InputFormatError(
            f"{where}, line {line}, column {col}: a number with {len(digits)} digits; "
            f"gloffset reads numbers of up to {_max_digits()} digits"
        ) from None
    except RecursionError:
        raise InputFormatError(f"{where}: JSON nested too deeply to read") from None


@contextlib.contextmanager
def collector_paused():
    """The garbage collector paused (and restored as it was) while a GeoJSON document is
    built and read: its hundreds of thousands of lists make no cycle, and the collector's
    passes over them (each time they come of age) cost about a third of the parse. The
    document is freed by reference counting once read, before the collector runs again."""
    collecting = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if collecting:
            gc.enable()


def _max_digits() -> int:
    get = getattr(sys, "get_int_max_str_digits", None)
    return get() if get is not None else 4300


def _short(value, width: int = 60) -> str:
    """``repr(value)``, cut to ``width`` characters, for messages about arbitrary input."""
    try:
        text = repr(value)
    except ValueError:  # an int too long to print
        text = f"<{type(value).__name__}>"
    return text if len(text) <= width else text[: width - 3] + "..."


_NESTING = {1: "a list of positions", 2: "a list of lists of positions", 3: "a list of polygons"}


def _coords(obj, depth: int, label: str) -> list:
    """Check the nesting of a coordinates array (``depth`` lists above the positions) and
    return it as nested lists of positions."""
    if obj is None:
        raise InputFormatError(f"{label}: missing 'coordinates'")
    if isinstance(obj, np.ndarray):
        obj = obj.tolist()
    if depth == 0:
        return obj
    if not isinstance(obj, (list, tuple)):
        raise InputFormatError(
            f"{label}: 'coordinates' are not nested as the geometry type requires: expected "
            f"{_NESTING[depth]}, got {_short(obj)}"
        )
    if depth == 1:
        kinds = set(map(type, obj))  # at C speed: no call per position
        if type(None) not in kinds and not any(issubclass(k, np.ndarray) for k in kinds):
            return list(obj)  # the positions as they are (what the call per position returns)
    return [_coords(o, depth - 1, label) for o in obj]


def _number(v) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))


#: The types of the numbers json.loads makes (bool, a subclass of int, is not one of them).
_PLAIN = {float, int}


def _position_array(coords, label: str) -> np.ndarray:
    """An (n, 2) float64 array of lon/lat from a list of GeoJSON positions."""
    if len(coords) == 0:
        return np.zeros((0, 2))
    try:  # the usual case, fast: positions of plain numbers, all of one length
        if set(map(type, itertools.chain.from_iterable(coords))) <= _PLAIN:
            if set(map(len, coords)) == {2}:  # lon/lat pairs: no nesting for numpy to find
                flat = itertools.chain.from_iterable(coords)
                return np.fromiter(flat, np.float64, 2 * len(coords)).reshape(-1, 2)
            arr = np.array(coords, dtype=np.float64)
            if arr.ndim == 2 and arr.shape[1] >= 2:
                return np.ascontiguousarray(arr[:, :2])
    except (TypeError, ValueError, OverflowError):
        pass
    rows = []  # anything else, position by position, with an error that names the first bad one
    for i, p in enumerate(coords):
        if not isinstance(p, (list, tuple)) or len(p) < 2 or not (_number(p[0]) and _number(p[1])):
            raise InputFormatError(
                f"{label} vertex {i}: a position is [lon, lat] (two numbers), got {_short(p)}"
            )
        try:
            rows.append((float(p[0]), float(p[1])))
        except OverflowError:
            raise InputFormatError(
                f"{label} vertex {i}: coordinate too large for a float ({_short(p)})"
            ) from None
    return np.asarray(rows, dtype=np.float64)


def parse(obj) -> Parts:
    """Flatten a GeoJSON object into labelled lon/lat :class:`Parts`."""
    try:
        return _parse(obj)
    except RecursionError:
        raise InputFormatError("GeoJSON nested too deeply to read") from None


def members(obj) -> list | None:
    """The features of a GeoJSON object: a FeatureCollection's list, ``[obj]`` for a
    Feature, None for a bare geometry (an error names a missing ``type`` or
    ``features``)."""
    if not isinstance(obj, dict) or "type" not in obj:
        raise InputFormatError("not a GeoJSON object: no 'type' member")
    kind = obj["type"]
    if kind == "FeatureCollection":
        feats = obj.get("features")
        if not isinstance(feats, list):
            raise InputFormatError("FeatureCollection has no 'features' list")
        return feats
    return [obj] if kind == "Feature" else None


def _parse(obj) -> Parts:
    parts = Parts()
    feats = members(obj)
    if feats is None:
        _geometry(obj, "geometry", parts)
    for i, f in enumerate(feats or ()):
        _feature(f, _feature_label(f, i), parts)
    return parts


def _feature_label(f, i: int) -> str:
    props = f.get("properties") if isinstance(f, dict) else None
    name = None
    if isinstance(props, dict):
        for key in ("name", "NAME", "name_en", "id"):
            if props.get(key) is not None:
                name = props[key]
                break
    if name is None and isinstance(f, dict) and f.get("id") is not None:
        name = f["id"]
    if name is None:
        return f"feature {i}"
    return f"feature {i} ({name if isinstance(name, str) and len(name) <= 60 else _short(name)})"


def _feature(f, label: str, parts: Parts) -> None:
    if not isinstance(f, dict) or f.get("type") != "Feature":
        raise InputFormatError(f"{label} is not a GeoJSON Feature")
    geom = f.get("geometry")
    if geom is None:  # RFC 7946 allows unlocated features; they carry no curve
        return
    _geometry(geom, label, parts)


def _polygon(rings, label: str, parts) -> None:
    """One polygon's rings (exterior first) into ``parts``, named ``label``."""
    if len(rings) == 0:
        raise InputFormatError(f"{label} has no rings (empty geometry)")
    parts.polygons.append([_position_array(r, f"{label} ring {k}") for k, r in enumerate(rings)])
    parts.polygon_labels.append(label)


def _geometry(g, label: str, parts: Parts) -> None:
    if not isinstance(g, dict) or "type" not in g:
        raise InputFormatError(f"{label}: geometry has no 'type'")
    kind = g["type"]
    c = g.get("coordinates")
    if kind == "Point":
        parts.points.append(_position_array([_coords(c, 0, label)], label))
        parts.point_labels.append(f"{label} Point")
    elif kind == "MultiPoint":
        for j, p in enumerate(_coords(c, 1, label)):
            parts.points.append(_position_array([p], f"{label} point {j}"))
            parts.point_labels.append(f"{label} point {j}")
    elif kind == "LineString":
        parts.lines.append(_position_array(_coords(c, 1, label), f"{label} LineString"))
        parts.line_labels.append(f"{label} LineString")
    elif kind == "MultiLineString":
        for j, line in enumerate(_coords(c, 2, label)):
            parts.lines.append(_position_array(line, f"{label} line {j}"))
            parts.line_labels.append(f"{label} line {j}")
    elif kind == "Polygon":
        _polygon(_coords(c, 2, label), f"{label} Polygon", parts)
    elif kind == "MultiPolygon":
        for j, poly in enumerate(_coords(c, 3, label)):
            _polygon(poly, f"{label} polygon {j}", parts)
    elif kind == "GeometryCollection":
        geoms = g.get("geometries")
        if not isinstance(geoms, list):
            raise InputFormatError(f"{label}: GeometryCollection has no 'geometries' list")
        for j, sub in enumerate(geoms):
            _geometry(sub, f"{label} geometry {j}", parts)
    else:
        raise InputFormatError(f"{label}: unsupported geometry type {_short(kind)}")


# --------------------------------------------------------------------------- writing

_AM_TOL = 1e-9  # degrees: a longitude within this of +-180 lies on the antimeridian


def _round(a: np.ndarray, digits: int | None) -> list:
    if digits is None:
        return a.tolist()
    if (
        not isinstance(digits, (int, np.integer))
        or isinstance(digits, (bool, np.bool_))
        or digits < 0
    ):
        raise OptionError(f"digits must be a whole number >= 0, got {_short(digits)}")
    return np.round(a, int(digits)).tolist()


def _crossing(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The point where the short arc a -> b meets the plane y = 0 (a, b on opposite sides)."""
    c = normalize(b[1] * a - a[1] * b)
    return c if np.dot(c, a + b) >= 0.0 else -c


def _split_ring(ring: np.ndarray) -> tuple[list[np.ndarray] | None, np.ndarray | None]:
    """Split a closed ring of unit vectors at the antimeridian.

    Returns (chains, lonlat): ``chains`` is None when the ring does not cross the
    antimeridian (``lonlat`` is then the ring in lon/lat), else a list of lon/lat
    chains whose first and last vertices lie on lon = +-180.
    """
    n = len(ring)
    side = ring[:, 1] >= 0.0  # half-open: y == 0 counts as east (+180 side)
    nxt = np.roll(ring, -1, axis=0)
    nside = np.roll(side, -1)
    change = side != nside
    crossings = []
    for i in np.flatnonzero(change):
        c = _crossing(ring[i], nxt[i])
        if c[0] < 0.0:  # crosses lon = 180, not the prime meridian
            crossings.append((i, c))
    lon, lat = xyz_to_lonlat(ring)
    if not crossings:
        return None, np.column_stack([lon, lat])
    chains = []
    for k, (i, c) in enumerate(crossings):
        j, _ = crossings[(k + 1) % len(crossings)]
        # chain: crossing after vertex i, vertices i+1 .. j, crossing after vertex j
        idx = np.arange(i + 1, i + 1 + ((j - i - 1) % n) + 1) % n
        first = 180.0 if side[idx[0]] else -180.0
        last = 180.0 if side[idx[-1]] else -180.0
        _, clat0 = xyz_to_lonlat(c)
        _, clat1 = xyz_to_lonlat(crossings[(k + 1) % len(crossings)][1])
        pts = np.column_stack([lon[idx], lat[idx]])
        # a vertex on the antimeridian takes the side of its chain (y >= 0: east, +180)
        near = np.abs(np.abs(pts[:, 0]) - 180.0) < _AM_TOL
        pts[near, 0] = np.where(side[idx][near], 180.0, -180.0)
        # one at either end of the chain is its crossing point: keep the crossing alone
        keep = np.ones(len(pts), dtype=bool)
        keep[[0, -1]] &= ~near[[0, -1]]
        if keep.any():
            pts = pts[keep]
        chain = np.vstack([[first, float(clat0)], pts, [last, float(clat1)]])
        chains.append(_expand_poles(chain, cyclic=False))
    return chains, None


def _perimeter(pt) -> float:
    """Counter-clockwise position on the boundary of [-180,180]x[-90,90] (from bottom-left)."""
    lon, lat = pt
    if lon >= 180.0 - _AM_TOL:
        return 360.0 + (lat + 90.0)
    return 900.0 + (90.0 - lat)  # left edge, going down


_CORNERS = [
    (360.0, (180.0, -90.0)),
    (540.0, (180.0, 90.0)),
    (900.0, (-180.0, 90.0)),
    (1080.0, (-180.0, -90.0)),
]


def _walk(t0: float, t1: float) -> list:
    """Corners passed when walking counter-clockwise along the window boundary from t0 to t1."""
    if t1 <= t0:
        t1 += 1080.0
    out = []
    for base in (0.0, 1080.0):
        for t, xy in _CORNERS:
            if t0 < t + base < t1:
                out.append(xy)
    return out


def _signed_area(ring: np.ndarray) -> float:
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _point_in_ring(pt, ring: np.ndarray) -> bool:
    x, y = pt
    xs, ys = ring[:, 0], ring[:, 1]
    xn, yn = np.roll(xs, -1), np.roll(ys, -1)
    cond = (ys > y) != (yn > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = xs + (y - ys) * (xn - xs) / (yn - ys)
    return bool(np.count_nonzero(cond & (x < xc)) % 2)


def _expand_poles(ring: np.ndarray, cyclic: bool = True) -> np.ndarray:
    """Replace a vertex at a pole by two vertices on the +-90 edge at its neighbours' lons."""
    polar = np.abs(ring[:, 1]) >= 90.0 - 1e-12
    if not polar.any() or polar.all():
        return ring
    out = []
    n = len(ring)
    for i in range(n):
        if polar[i] and (cyclic or 0 < i < n - 1):
            prev_lon = ring[(i - 1) % n, 0]
            next_lon = ring[(i + 1) % n, 0]
            out.append([prev_lon, ring[i, 1]])
            out.append([next_lon, ring[i, 1]])
        else:
            out.append(ring[i])
    return np.asarray(out)


def _close(ring: np.ndarray) -> np.ndarray:
    # drop consecutive duplicates, then repeat the first vertex at the end (RFC 7946)
    keep = np.ones(len(ring), dtype=bool)
    keep[1:] = np.any(ring[1:] != ring[:-1], axis=1)
    ring = ring[keep]
    if len(ring) > 1 and np.all(ring[0] == ring[-1]):
        ring = ring[:-1]
    return np.vstack([ring, ring[:1]])


def rings_to_geometry(rings, north_pole_inside: bool, digits: int | None = None) -> dict:
    """RFC 7946 (Multi)Polygon for rings of unit vectors with their interior on the left.

    Parameters
    ----------
    rings : list of (n, 3) arrays
        Closed rings (first vertex not repeated), already densified: edges are
        written as straight lines in lon/lat.
    north_pole_inside : bool
        Whether the region contains the north pole; needed only when no ring
        crosses the antimeridian, to tell a region that covers both poles (the
        whole lon/lat window minus holes) from one that covers neither.
    digits : int, optional
        Round coordinates to this many decimals.

    Notes
    -----
    Rings crossing the antimeridian are split there (the crossing latitude is the
    exact great-circle crossing of the arc) and closed along the window edges
    lon = +-180 and lat = +-90 by walking the window boundary counter-clockwise,
    which also closes rings around a pole. Exterior rings come out
    counter-clockwise and holes clockwise, holes inside their exterior.
    """
    closed: list[np.ndarray] = []  # lon/lat rings not touching the window edges
    chains: list[np.ndarray] = []
    for ring in rings:
        ring = np.asarray(ring, dtype=np.float64)
        if len(ring) < 3:
            continue
        ch, ll = _split_ring(ring)
        if ch is None:
            assert ll is not None  # a ring that does not cross
            closed.append(_expand_poles(ll))
        else:
            chains.extend(ch)

    pieces: list[np.ndarray] = []
    if chains:
        starts = np.array([_perimeter(c[0]) for c in chains])
        used = np.zeros(len(chains), dtype=bool)
        for k in range(len(chains)):
            if used[k]:
                continue
            out = []
            cur = k
            while not used[cur]:
                used[cur] = True
                out.append(chains[cur])
                t_end = _perimeter(chains[cur][-1])
                # next chain start counter-clockwise from t_end
                d = (starts - t_end) % 1080.0
                nxt = int(np.argmin(d))
                corners = _walk(t_end, float(starts[nxt]))
                if corners:
                    out.append(np.asarray(corners))
                cur = nxt
            pieces.append(np.vstack(out))
    elif north_pole_inside:
        pieces.append(np.array([[-180.0, -90.0], [180.0, -90.0], [180.0, 90.0], [-180.0, 90.0]]))

    exteriors = [r for r in pieces] + [r for r in closed if _signed_area(r) > 0]
    holes = [r for r in closed if _signed_area(r) <= 0]
    polys: list[list[np.ndarray]] = [[e] for e in exteriors]
    for h in holes:
        probe = h[len(h) // 2]
        owner = None
        for i, e in enumerate(exteriors):
            if _point_in_ring(probe, e):
                if owner is None or abs(_signed_area(e)) < abs(_signed_area(exteriors[owner])):
                    owner = i
        if owner is None:  # numerically outside every exterior: keep the area as its own ring
            polys.append([h[::-1]])
        else:
            polys[owner].append(h)
    coords = [[_round(_close(r), digits) for r in poly] for poly in polys]
    if len(coords) == 1:
        return {"type": "Polygon", "coordinates": coords[0]}
    return {"type": "MultiPolygon", "coordinates": coords}


def lines_to_geometry(lines, digits: int | None = None) -> dict:
    """RFC 7946 MultiLineString for open lines of unit vectors, split at the antimeridian."""
    out = []
    for line in lines:
        line = np.asarray(line, dtype=np.float64)
        lon, lat = xyz_to_lonlat(line)
        cur = [[float(lon[0]), float(lat[0])]]
        for i in range(len(line) - 1):
            a, b = line[i], line[i + 1]
            if (a[1] >= 0.0) != (b[1] >= 0.0):
                c = _crossing(a, b)
                if c[0] < 0.0:
                    _, clat = xyz_to_lonlat(c)
                    edge = 180.0 if a[1] >= 0.0 else -180.0
                    cur.append([edge, float(clat)])
                    out.append(cur)
                    cur = [[-edge, float(clat)]]
            cur.append([float(lon[i + 1]), float(lat[i + 1])])
        out.append(cur)
    coords = [_round(np.asarray(c), digits) for c in out if len(c) >= 2]
    return {"type": "MultiLineString", "coordinates": coords}


def region_feature(region, *, tolerance: float, digits: int | None = None, properties=None):
    """A resolved offset (:class:`gloffset.ResolvedOffset`) as an RFC 7946 Feature.

    Its arcs are densified (``region.sample(tolerance)``) so that no written edge strays
    more than ``tolerance`` (radians) from its arc; rings are cut at the antimeridian,
    exterior rings run counter-clockwise and holes clockwise (:func:`rings_to_geometry`,
    told by ``region.contains_xyz`` whether the north pole is inside). ``properties``
    default to ``distance_m`` and ``distance``, both the angle (a resolved offset lies on
    the unit sphere).
    """
    props = dict(properties) if properties else distance_properties(region.distance)
    rings = region.sample(tolerance)
    north = bool(region.contains_xyz(np.array([[0.0, 0.0, 1.0]]))[0])
    if not rings and not north:
        geom = {"type": "MultiPolygon", "coordinates": []}
    else:
        geom = rings_to_geometry(rings, north, digits)
    return {"type": "Feature", "properties": props, "geometry": geom}


def offset_feature(
    off, *, tolerance: float, digits: int | None = None, raw: bool = False, method="general"
) -> dict:
    """An offset (:class:`gloffset.Offset`) as an RFC 7946 Feature.

    By default its resolved boundary (``off.resolve(method)``, :func:`region_feature`):
    valid polygons with holes, densified to ``tolerance`` (radians). ``raw=True`` writes
    the raw offset curves of Sec. 4.1 as what they are: a MultiLineString of closed rings
    that may cross themselves and each other (property ``raw``: true). At distance 0, the
    input's polygons (``off.shape.to_geojson``). The properties are ``distance_m``, the
    distance in the units of ``off.radius`` (metres for the default radius), and
    ``distance``, the distance as given (``off.given``, else the angle).
    """
    given = off.distance if off.given is None else off.given
    props = distance_properties(given, off.radius)
    if off.distance == 0.0:
        feat = off.shape.to_geojson(digits=digits)
        feat["properties"] = props
        return feat
    if not raw:
        return region_feature(
            off.resolve(method), tolerance=tolerance, digits=digits, properties=props
        )
    props["raw"] = True
    closed = [np.vstack([r, r[:1]]) for r in off.sample(tolerance) if len(r)]
    geom = lines_to_geometry(closed, digits)
    return {"type": "Feature", "properties": props, "geometry": geom}


def disc_geometry(rings, i: int, digits: int | None = None) -> dict:
    """Row ``i`` of the offsets of many points or segments
    (:class:`gloffset.vector.discs.Rings`) as an RFC 7946 geometry: its lon/lat ring as a
    Polygon, or, for a ring across the antimeridian or round a pole, the geometry of
    :func:`rings_to_geometry`."""
    if i in rings.special:
        ring, north = rings.special[i]
        return rings_to_geometry([ring], north, digits)
    return {"type": "Polygon", "coordinates": [_round(rings.lonlat[i], digits)]}
