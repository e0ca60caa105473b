"""Per-feature offsets: each feature of an input offset on its own, its properties kept.

The default everywhere is the union (the region of an input is the union of its
polygons). :func:`offset_each` is the explicit alternative: every GeoJSON feature gives one
output feature, its offset region, with the feature's properties and a ``distance``
property. Points and single segments, the features that come by the hundred thousand,
are offset all at once (:mod:`gloffset.vector.discs`); every other feature goes through
:func:`gloffset.offset` and the resolve step alone. A feature without geometry is kept
with a null geometry. GeoJSON features in, GeoJSON features out: this sits above both
:mod:`gloffset.vector` (the offsets) and :mod:`gloffset.io.geojson` (their writing).
"""

from __future__ import annotations

from typing import TypeGuard, cast

import numpy as np

from .errors import InputFormatError, InvalidDistanceError, InvalidGeometryError
from .io.geojson import disc_geometry, offset_feature, parse
from .shape import Shape
from .units import to_angle
from .vector import discs
from .vector.arcrings import DEFAULT_TOLERANCE
from .vector.offset import offset

__all__ = ["offset_each", "simple_kind", "POINT", "SEGMENT", "GENERAL", "NONE"]

#: Kinds of a feature's geometry for the per-feature paths.
NONE, POINT, SEGMENT, GENERAL = 0, 1, 2, 3


def simple_kind(geometry) -> tuple[int, list | None]:
    """``(kind, coordinates)``: a Point (one position), a LineString of two positions (a
    segment), no geometry, or anything else (GENERAL, coordinates None)."""
    if geometry is None:
        return NONE, None
    if not isinstance(geometry, dict):
        return GENERAL, None
    kind, c = geometry.get("type"), geometry.get("coordinates")
    if kind == "Point" and _position(c):
        return POINT, [c[:2], c[:2]]
    if kind == "LineString" and isinstance(c, list) and len(c) == 2:
        if _position(c[0]) and _position(c[1]) and c[0][:2] != c[1][:2]:
            return SEGMENT, [c[0][:2], c[1][:2]]
    return GENERAL, None


def _position(p) -> TypeGuard[list | tuple]:
    return (
        isinstance(p, (list, tuple))
        and len(p) >= 2
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in p[:2])
    )


def offset_each(
    features: list[dict],
    d: float | str,
    *,
    radius: float = 1.0,
    tolerance: float = DEFAULT_TOLERANCE,
    resolution: int | None = None,
    digits: int | None = None,
    raw: bool = False,
    method: str = "general",
    progress=None,
) -> list[dict]:
    """The offset of each GeoJSON feature alone, as GeoJSON features with its properties.

    ``d`` is a distance in the units of ``radius`` (an angle in radians by default) or a
    string with a unit such as ``"127km"``; messages quote it as given. ``tolerance`` is an
    angle (radians); ``resolution`` (segments per quarter
    circle), if given, sets the density of the circles of points and segments, else they
    are densified to ``tolerance`` as every other arc is. The output's properties are the
    input's; the caller adds the distance. ``progress``, if given, is called with no
    argument once per feature offset (the points and segments after their batch).
    """
    given, d = d, to_angle(d, radius)
    if not 0.0 < d < np.pi / 2:
        simple = []  # inward offsets or d = 0: every feature goes the general way
    else:
        simple = [simple_kind(f.get("geometry") if isinstance(f, dict) else None) for f in features]
    res = resolution if resolution is not None else discs.resolution_for(d, tolerance)
    out: list[dict | None] = [None] * len(features)
    for kind in (POINT, SEGMENT):
        rows = [i for i, (k, _) in enumerate(simple) if k == kind]
        if not rows:
            continue
        ends = np.array([simple[i][1] for i in rows], dtype=np.float64)
        labels = _labeller(features, rows)
        if kind == POINT:
            rings = discs.discs(ends[:, 0], d, res, labels=labels)
        else:
            rings = discs.stadiums(ends[:, 0], ends[:, 1], d, res, labels=labels)
        for j, i in enumerate(rows):
            out[i] = _feature(features[i], disc_geometry(rings, j, digits))
            if progress is not None:
                progress()
    for i, f in enumerate(features):
        if out[i] is None:
            out[i] = _general(f, i, given, radius, tolerance, digits, raw, method)
            if progress is not None:
                progress()
    return cast("list[dict]", out)  # every feature has its offset now


def _labeller(features, rows):
    def label(j: int) -> str:
        i = rows[j]
        parts = parse({"type": "FeatureCollection", "features": [features[i]]})
        return (parts.point_labels + parts.line_labels + [f"feature {i}"])[0].replace(
            "feature 0", f"feature {i}", 1
        )

    return label


def _feature(f, geometry) -> dict:
    props = f.get("properties") if isinstance(f, dict) else None
    return {"type": "Feature", "properties": dict(props or {}), "geometry": geometry}


def _general(f, i: int, distance, radius, tolerance, digits, raw, method) -> dict:
    if not isinstance(f, dict) or f.get("geometry") is None:
        return _feature(f, None)
    try:
        shape = Shape.from_geojson({"type": "FeatureCollection", "features": [f]})
        feat = offset_feature(
            offset(shape, distance, radius=radius),
            tolerance=tolerance,
            digits=digits,
            raw=raw,
            method=method,
        )
    except (InvalidGeometryError, InputFormatError) as exc:  # named as feature 0 alone
        raise type(exc)(str(exc).replace("feature 0", f"feature {i}", 1)) from None
    except InvalidDistanceError as exc:
        raise InvalidDistanceError(f"feature {i}: {exc}") from None
    return _feature(f, feat["geometry"])
