"""``gloffset offset``: the vector offset of an input, written as GeoJSON or a vector file.

By default the boundary of the offset region is written as valid polygons (self-
intersections removed, parts united, holes kept; see :mod:`gloffset.vector.selfintersect`);
``--raw`` writes the raw offset rings of the paper's Sec. 4.1 instead. ``--each`` offsets
every feature on its own and keeps its properties (:mod:`gloffset.each`). The output
is GeoJSON, or a GeoPackage, Shapefile, FlatGeobuf or GeoParquet file by its name
(:mod:`gloffset.io.vectorfile`). Every output feature has the fields ``distance_m`` (the
distance in metres: the geodesic length with ``--ellipsoid``, else on the sphere of
``--radius``) and ``distance`` (as given, e.g. ``"127km"``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import click

from ..each import offset_each
from ..ellipsoid import Ellipsoid
from ..errors import OptionError
from ..geodesic_offset import offset as geodesic_offset
from ..io.features import features as _features
from ..io.features import load
from ..io.geojson import offset_feature
from ..io.output import check_output, write_bytes
from ..io.vectorfile import WRITE_FORMATS, check_writable
from ..io.vectorfile import write as write_vector
from ..shape import read
from ..units import distance_properties
from ..vector.offset import offset as _offset
from . import main
from .options import (
    Stages,
    angle,
    choice_option,
    distance_option,
    ellipsoid_option,
    input_options,
    metres,
    parse_ellipsoid,
    radius_option,
)


@main.command("offset")
@click.argument("input", metavar="INPUT")
@distance_option
@radius_option
@input_options
@ellipsoid_option
@click.option(
    "-o",
    "--output",
    default="-",
    show_default=True,
    help="Output file: GeoJSON (- for stdout), or .gpkg, .shp, .fgb, .parquet.",
)
@click.option(
    "--tolerance",
    default=None,
    help="Largest deviation of the written edges from the true arcs (a distance; default "
    "1e-6rad, or 1m with --ellipsoid: every point of the rings within it of DIST).",
)
@click.option(
    "--digits",
    type=click.IntRange(min=0),
    default=None,
    help="Round coordinates to this many decimals (0 or more).",
)
@click.option(
    "--raw",
    is_flag=True,
    help="Write the raw offset curves (paper Sec. 4.1) before self-intersections and "
    "overlaps are removed: closed rings as LineStrings (a MultiLineString per feature, "
    "property raw: true), as they may cross themselves and each other.",
)
@choice_option(
    "--method",
    choices=("general", "paper"),
    help="Self-intersection removal: exact and general, or the paper's Algorithm 1.",
)
@click.option(
    "--each",
    is_flag=True,
    help="Offset each feature on its own, keeping its properties (default: the union).",
)
def offset_cmd(
    input,
    distance,
    radius,
    ellipsoid,
    layer,
    where,
    densify,
    output,
    tolerance,
    digits,
    raw,
    method,
    each,
):
    """Offset the curves and polygons of INPUT (GeoJSON or another vector file, - for
    GeoJSON on stdin).

    With --ellipsoid, DIST is a geodesic length in metres on that ellipsoid (polygon
    edges are geodesics) and the rings are densified until every point of them lies
    within --tolerance of DIST.

    On a terminal the stages (reading, removing self-intersections, densifying, writing;
    with --each the features done) are shown on stderr; GLOFFSET_PROGRESS=1 shows them
    anywhere, GLOFFSET_PROGRESS=0 nowhere."""
    ell = parse_ellipsoid(ellipsoid)
    if ell is not None:
        if raw or method != "general" or each:
            raise OptionError(
                "--raw, --method paper and --each are for the sphere, not --ellipsoid"
            )
        metres(distance)  # read before the work
        tol = metres(tolerance or "1m")
    else:
        angle(distance, radius)  # read before the work
        tol = angle(tolerance or "1e-6rad", radius)
    check_output(output)  # fail before the work
    vector = str(output).lower().endswith(tuple(WRITE_FORMATS))
    if vector:
        check_writable(output)
    with Stages(3 if each or ell is not None or raw else 4) as stages:
        opts = _Options(distance, radius, ell, each, tol, digits, raw, method)
        feats = _offsets(stages, input, {"layer": layer, "where": where, "densify": densify}, opts)
        props = distance_properties(distance, 1.0 if ell is not None else radius)
        for feat in feats:
            feat["properties"].update(props)
        stages.stage("writing " + ("stdout" if output == "-" else repr(str(output))))
        if vector:
            write_vector(output, feats)
            return
        text = json.dumps({"type": "FeatureCollection", "features": feats})
        write_bytes(output, (text + "\n").encode("utf-8"))


@dataclass(frozen=True)
class _Options:
    """What ``offset`` makes of its input: the distance as given, the sphere's radius or
    the ellipsoid (None: the sphere), ``--each``, the tolerance (an angle, or metres on
    the ellipsoid), ``--digits``, ``--raw`` and ``--method``."""

    distance: str
    radius: float
    ell: Ellipsoid | None
    each: bool
    tolerance: float
    digits: int | None
    raw: bool
    method: str


def _offsets(stages, input, source: dict, o: _Options) -> list:
    """The output features, the stages reported to ``stages`` (all but the writing)."""
    if o.each:
        stages.stage("reading the input")
        feats = _features(load(input, **source))
        stages.stage("offsetting each feature", len(feats))
        return offset_each(
            feats,
            o.distance,
            radius=o.radius,
            tolerance=o.tolerance,
            digits=o.digits,
            raw=o.raw,
            method=o.method,
            progress=stages.tick,
        )
    stages.stage("reading the input")
    shape = read(input, **source)
    if o.ell is not None:
        stages.stage(f"offsetting on {o.ell}")
        off = geodesic_offset(shape, metres(o.distance), ellipsoid=o.ell, tolerance=o.tolerance)
        return [off.to_geojson(digits=o.digits)]
    off = _offset(shape, o.distance, radius=o.radius)
    if not o.raw and off.distance != 0.0:
        stages.stage("removing self-intersections and overlaps")
        off.resolve(o.method)  # kept on the offset for its writing
    stages.stage("densifying the arcs and cutting at the antimeridian")
    return [offset_feature(off, tolerance=o.tolerance, digits=o.digits, raw=o.raw, method=o.method)]
