"""``gloffset offset``: the vector offset of an input, written as GeoJSON or a vector file.

By default the boundary of the offset region is written as valid polygons (self-
intersections removed, parts united, holes kept; see :mod:`gloffset.vector.selfintersect`);
``--raw`` writes the raw offset rings of the paper's Sec. 4.1 instead. ``--each`` offsets
every feature on its own and keeps its properties (:mod:`gloffset.vector.each`). The output
is GeoJSON, or a GeoPackage, Shapefile, FlatGeobuf or GeoParquet file by its name
(:mod:`gloffset.io.vectorfile`), with a ``distance`` field.
"""

from __future__ import annotations

import json

import click

from ..errors import OptionError
from ..geodesic_offset import offset as geodesic_offset
from ..io.features import features as _features
from ..io.features import load
from ..io.output import check_output, write_bytes
from ..io.vectorfile import WRITE_FORMATS, check_writable
from ..io.vectorfile import write as write_vector
from ..shape import read
from ..vector.each import offset_each
from ..vector.offset import offset as _offset
from . import main
from .options import (
    angle,
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
    help="Write the raw offset rings (self-intersections and overlaps left in).",
)
@click.option(
    "--method",
    type=click.Choice(["general", "paper"]),
    default="general",
    show_default=True,
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
    within --tolerance of DIST."""
    ell = parse_ellipsoid(ellipsoid)
    if ell is not None:
        if raw or method != "general" or each:
            raise OptionError(
                "--raw, --method paper and --each are for the sphere, not --ellipsoid"
            )
        m, tol = metres(distance), metres(tolerance or "1m")
    else:
        d, tol = angle(distance, radius), angle(tolerance or "1e-6rad", radius)
    check_output(output)  # fail before the work
    vector = str(output).lower().endswith(tuple(WRITE_FORMATS))
    if vector:
        check_writable(output)
    if each:
        feats = offset_each(
            _features(load(input, layer=layer, where=where, densify=densify)),
            d,
            tolerance=tol,
            digits=digits,
            raw=raw,
            method=method,
        )
    elif ell is not None:
        shape = read(input, layer=layer, where=where, densify=densify)
        off = geodesic_offset(shape, m, ellipsoid=ell, tolerance=tol)
        feats = [off.to_geojson(digits=digits)]
    else:
        shape = read(input, layer=layer, where=where, densify=densify)
        off = _offset(shape, d, radius=1.0)
        feats = [off.to_geojson(tolerance=tol, digits=digits, raw=raw, method=method)]
    for feat in feats:
        feat["properties"]["distance"] = distance
    if vector:
        write_vector(output, feats)
        return
    text = json.dumps({"type": "FeatureCollection", "features": feats})
    write_bytes(output, (text + "\n").encode("utf-8"))
