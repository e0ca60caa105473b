"""``gloffset.buffer``: exact metric buffers of GeoPandas GeoSeries and GeoDataFrames.

GeoPandas buffers are planar: on lon/lat data a distance is in degrees (ellipses away
from the equator, broken at the antimeridian), and the usual recipe reprojects each
feature to its own azimuthal projection. :func:`buffer` takes the lon/lat data as it is
and returns each feature's region within a distance in metres on the sphere, in
EPSG:4326: polygons whose every vertex lies at the distance from the feature (to
rounding), cut at the antimeridian and closed along the poles as RFC 7946 asks.

Points and two-point lines are buffered all at once with numpy
(:mod:`gloffset.vector.discs`), so 100,000 of them take about a second; every other
feature goes through :func:`gloffset.offset` and its resolve step (milliseconds each).
geopandas is imported only when :func:`buffer` is called (the ``geopandas`` extra).
"""

from __future__ import annotations

import sys
import warnings

import numpy as np

from .errors import InputFormatError, InvalidDistanceError, InvalidGeometryError, OptionError
from .geometry.sphere import angle, lonlat_to_xyz
from .io.crs import is_lonlat
from .io.geojson import disc_geometry, offset_feature
from .shape import Shape
from .units import EARTH_RADIUS, VECTOR_LIMIT, check_radius, offset_angle, to_angle
from .vector import discs
from .vector.offset import Offset

__all__ = ["buffer"]

#: shapely's geometry type ids: Point, LineString, LinearRing, MultiPoint, MultiLineString
_CURVES = (0, 1, 2, 4, 5)


def _geopandas():
    try:
        import geopandas
        import shapely
    except ImportError as exc:
        raise InputFormatError(
            f"gloffset.buffer takes a GeoSeries or GeoDataFrame and needs {exc.name}: "
            "pip install 'gloffset[geopandas]'"
        ) from None
    return geopandas, shapely


def _lonlat_series(gpd, data):
    """Return the GeoSeries of ``data`` in lon/lat, or an error for a projected CRS."""
    if isinstance(data, gpd.GeoDataFrame):
        series = data.geometry
    elif isinstance(data, gpd.GeoSeries):
        series = data
    else:
        raise InputFormatError(
            f"gloffset.buffer takes a GeoSeries or GeoDataFrame, not {type(data).__name__}; "
            "use gloffset.offset for other geometry"
        )
    crs = series.crs
    if crs is None or is_lonlat(crs, "the GeoSeries"):
        return series
    if crs.is_projected or not crs.is_geographic:
        raise InputFormatError(
            f"gloffset.buffer measures metres on the sphere from lon/lat, but the data are in "
            f"the projected CRS {crs.to_string()!r} ({crs.name}); give lon/lat, e.g. "
            "data.to_crs('EPSG:4326')"
        )
    return series.to_crs("EPSG:4326")  # another geographic CRS: lon/lat on another datum


def _angles(distance, n: int, radius: float) -> np.ndarray:
    """Return per-feature distances as angles (radians).

    One distance for all or one per feature, each a number in the units of ``radius`` or
    a string with a unit (``"500m"``), read by :func:`gloffset.units.to_angle`.
    """
    if np.ndim(distance) == 0:
        return np.full(n, to_angle(distance, radius))
    arr = np.asarray(distance)
    if arr.shape != (n,):
        raise InvalidDistanceError(
            f"distance must be one value or one per feature ({n}), got shape {arr.shape}"
        )
    if arr.dtype.kind in "OUS":  # strings with units, or strings and numbers
        return np.array([to_angle(x, radius) for x in arr.tolist()], dtype=np.float64)
    arr = arr.astype(np.float64)
    if not np.isfinite(arr).all():
        raise InvalidDistanceError("distance must be finite")
    return arr / check_radius(radius)


def _check_limit(d: np.ndarray, distance, index) -> None:
    """Refuse distances of a quarter of a great circle or more, naming the first row."""
    far = np.flatnonzero(np.abs(d) >= VECTOR_LIMIT)
    if len(far):
        i = int(far[0])
        given = distance if np.ndim(distance) == 0 else np.ravel(distance)[i]
        given = given if isinstance(given, str) else float(given)
        raise InvalidDistanceError(
            f"distance {given!r} of row {index[i]!r} is {abs(d[i]):.4g} rad on the sphere: "
            "buffers need less than a quarter of a great circle (pi/2 rad)"
            + (f"; {len(far)} rows are that far" if len(far) > 1 else "")
        )


def buffer(
    data,
    distance,
    *,
    each: bool = True,
    resolution: int = 16,
    radius=EARTH_RADIUS,
    progress=False,
):
    """Return the region within ``distance`` of each feature of a GeoSeries or GeoDataFrame.

    Parameters
    ----------
    data : geopandas.GeoSeries or geopandas.GeoDataFrame
        Lon/lat geometry (EPSG:4326, OGC:CRS84, no CRS, or another geographic CRS,
        transformed to EPSG:4326). A projected CRS is refused with a message.
    distance : float, str or array of floats or str
        In the units of ``radius`` (metres by default), or a string such as ``"500m"``;
        one per feature or one for all. Negative distances shrink polygons; points and
        lines then give empty polygons (so do geometry collections without polygons).
        Less than a quarter of a great circle; a farther distance raises
        :class:`~gloffset.InvalidDistanceError` naming the row.
    each : bool
        True (the default): each feature alone, as GeoPandas buffers. False: the union
        of all features' regions, as a GeoSeries of one geometry.
    resolution : int
        Segments per quarter circle, as in GeoPandas: the vertices of a point's circle;
        the arcs of other features are densified to the same closeness.
    radius : float
        Sphere radius (default :data:`gloffset.EARTH_RADIUS`, metres).
    progress : bool or callable
        False (the default): nothing. True: a progress bar of the rows on stderr (tqdm),
        for long runs (the 234 features of ``data/countries_10m.geojson`` take 15 s or
        more on 2 cores). A callable: called as ``progress(done, total)`` as rows are
        buffered (points and two-point lines at once, the others one by one), ``done``
        rising to ``total``, the rows (1 with ``each=False``). The buffers are the same
        either way.

    Returns
    -------
    A GeoSeries (for a GeoSeries, or with ``each=False``) or a copy of the GeoDataFrame
    with the buffers as its geometry, in EPSG:4326 with the input's index.

    Notes
    -----
    Rows are buffered one by one as GeoPandas does: a missing or empty geometry gives
    None, a LinearRing is buffered as its line, and a row whose geometry cannot be
    buffered (a coordinate out of range, a line of one distinct point...) gives None
    too, with one ``UserWarning`` for the whole call that names those rows (their index
    labels) and what is wrong with each; the other rows are buffered as usual. With
    ``each=False`` the rows are one input, and a bad row raises
    :class:`~gloffset.InvalidGeometryError`.
    """
    if not (isinstance(progress, bool) or progress is None or callable(progress)):
        raise OptionError(f"progress must be True, False or a callable, got {progress!r}")
    gpd, shapely = _geopandas()
    series = _lonlat_series(gpd, data)
    res = discs.segments_per_quarter(resolution)
    if not each:
        if not isinstance(distance, str) and np.size(distance) != 1:
            raise InvalidDistanceError("each=False (the union) takes one distance")
        given = np.ravel(distance)[0].item() if not isinstance(distance, str) else distance
        shape = Shape.from_geojson(series.__geo_interface__)
        one = offset_angle(shape, given, radius, limit=VECTOR_LIMIT)  # checked as offset() does
        with _Rows(progress, 1) as rows:
            geom = _general(shapely, shape, one, res)
            rows.add(1)
        return gpd.GeoSeries([geom], crs="EPSG:4326")
    d = _angles(distance, len(series), radius)
    _check_limit(d, distance, series.index)
    with _Rows(progress, len(series)) as rows:
        geoms, bad = _buffer_each(shapely, np.asarray(series.values, dtype=object), d, res, rows)
    if bad:
        _warn_bad_rows(bad, series.index, len(series))
    out = gpd.GeoSeries(geoms, index=series.index, crs="EPSG:4326")
    if isinstance(data, gpd.GeoDataFrame):
        frame = data.copy()
        frame[frame.geometry.name] = out
        return frame.set_crs("EPSG:4326", allow_override=True)
    return out


def _tolerance(d: float, res: int) -> float:
    """Return the chord deviation of a radius-``d`` circle drawn with ``res`` segments a quarter.

    What every arc is densified to.
    """
    return max(float(np.sin(abs(d)) * (1.0 - np.cos(np.pi / (4 * res)))), 1e-15)


def _general(shapely, shape, d: float, res: int):
    """Return the buffer of ``shape`` at the angle ``d`` (checked by the caller)."""
    feat = offset_feature(Offset(shape, d), tolerance=_tolerance(d, res))
    return shapely.geometry.shape(feat["geometry"])


class _Rows:
    """Count the rows buffered so far for ``buffer``'s ``progress``.

    A bar on stderr for True, the callable's ``(done, total)`` otherwise; a context
    manager that closes the bar.
    """

    def __init__(self, progress, total: int):
        self.call = None if isinstance(progress, bool) or progress is None else progress
        self.bar = None
        if progress is True:
            from tqdm import tqdm

            self.bar = tqdm(total=total, desc="gloffset.buffer", unit=" rows", file=sys.stderr)
        self.done, self.total = 0, total

    def add(self, n: int) -> None:
        if n <= 0:
            return
        self.done += n
        if self.bar is not None:
            self.bar.update(n)
        if self.call is not None:
            self.call(self.done, self.total)

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        if self.bar is not None:
            self.bar.close()


def _buffer_each(shapely, geoms: np.ndarray, d: np.ndarray, res: int, count: _Rows):
    """Buffers of an array of shapely geometries, and the rows that cannot be buffered.

    The simple ones all at once, and ``{row: message}`` for the rows that cannot be
    buffered (None in the output); ``count`` counts the rows done.
    """
    out = np.empty(len(geoms), dtype=object)
    missing = shapely.is_missing(geoms) | shapely.is_empty(geoms)
    # None is shapely's missing geometry (numpy's stub takes no None as an array-like)
    present = np.where(missing, None, geoms)  # type: ignore[call-overload]
    kind = np.where(missing, -1, shapely.get_type_id(present))
    rings = np.flatnonzero(kind == 2)
    if len(rings):  # a LinearRing is buffered as its line, as GeoPandas does
        geoms = geoms.copy()
        for i in rings.tolist():
            geoms[i] = shapely.LineString(geoms[i].coords)
        kind[rings] = 1
    ncoord = shapely.get_num_coordinates(geoms)
    curve = np.isin(kind, _CURVES)
    out[missing] = None
    out[curve & (d <= 0)] = shapely.Polygon()
    ok = (d > 0) & (d < np.pi / 2)
    points = ok & (kind == 0) & (ncoord == 1)
    points[points] = _in_range(shapely.get_coordinates(geoms[points]))
    segments = ok & (kind == 1) & (ncoord == 2)
    segments[segments] = _plain_segments(shapely, geoms[segments])
    for rows, make in ((points, discs.discs), (segments, discs.stadiums)):
        sel = np.flatnonzero(rows)
        _simple(shapely, geoms, out, sel, make, d[sel], res)
    general = ~missing & ~points & ~segments & ~(curve & (d <= 0))
    count.add(len(geoms) - int(np.count_nonzero(general)))
    bad: dict[int, str] = {}
    for i in np.flatnonzero(general).tolist():
        try:
            shape = Shape.from_geojson(shapely.geometry.mapping(geoms[i]))
            if d[i] <= 0.0 and not shape.rings:  # points and lines only: nothing is left
                out[i] = shapely.Polygon()
            else:
                out[i] = _general(shapely, shape, float(d[i]), res)
        except (InvalidGeometryError, InputFormatError) as exc:
            out[i], bad[i] = None, str(exc)
        count.add(1)
    return out, bad


def _warn_bad_rows(bad: dict, index, n: int) -> None:
    """One warning naming the rows that could not be buffered (the first five with why)."""
    rows = list(bad)
    why = "; ".join(f"row {index[i]!r}: {bad[i]}" for i in rows[:5])
    more = f"; and {len(rows) - 5} more" if len(rows) > 5 else ""
    labels = ", ".join(repr(index[i]) for i in rows[:20]) + (", ..." if len(rows) > 20 else "")
    warnings.warn(
        f"gloffset.buffer: {len(rows)} of {n} rows could not be buffered and are None "
        f"(rows {labels}): {why}{more}",
        UserWarning,
        stacklevel=3,
    )


def _in_range(xy: np.ndarray) -> np.ndarray:
    """Which positions (n, 2) are finite lon/lat in range.

    The others go the general way, which names what is wrong with them.
    """
    ok = np.isfinite(xy).all(axis=-1) & (np.abs(xy[..., 1]) <= 90)
    return ok & (np.abs(xy[..., 0]) <= 180)


def _plain_segments(shapely, geoms: np.ndarray) -> np.ndarray:
    """Which two-point lines are plain segments (ends distinct, not antipodal, in range).

    The others go the general way, which names what is wrong with them.
    """
    xy = shapely.get_coordinates(geoms).reshape(len(geoms), 2, 2)
    ok = np.asarray(_in_range(xy).all(axis=1))
    a = lonlat_to_xyz(*np.where(ok[:, None], xy[:, 0], 0.0).T)
    b = lonlat_to_xyz(*np.where(ok[:, None], xy[:, 1], 0.0).T)
    ang = angle(a, b)
    return ok & (ang > 1e-9) & (ang < np.pi - 1e-9)


def _simple(shapely, geoms, out, sel: np.ndarray, make, d: np.ndarray, res: int) -> None:
    """Buffer points (circles) or segments (stadiums) ``sel`` with numpy.

    ``d``: their distances (radians).
    """
    if not len(sel):
        return
    xy = shapely.get_coordinates(geoms[sel]).reshape(len(sel), -1, 2)
    labels = _label(sel)
    if make is discs.discs:
        rings = discs.discs(xy[:, 0], d, res, labels=labels)
    else:
        rings = discs.stadiums(xy[:, 0], xy[:, 1], d, res, labels=labels)
    plain = np.ones(len(sel), dtype=bool)
    plain[list(rings.special)] = False
    out[sel[plain]] = shapely.polygons(rings.lonlat[plain])
    for j in rings.special:
        out[sel[j]] = shapely.geometry.shape(disc_geometry(rings, j))


def _label(rows: np.ndarray):
    return lambda j: f"feature {int(rows[j])}"
