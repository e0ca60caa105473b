"""``gloffset offset``: the vector offset of a GeoJSON file, written as GeoJSON.

By default the boundary of the offset region is written as valid polygons (self-
intersections removed, parts united, holes kept; see :mod:`gloffset.vector.selfintersect`);
``--raw`` writes the raw offset rings of the paper's Sec. 4.1 instead.
"""

from __future__ import annotations

import json

import click

from ..errors import OptionError
from ..geodesic_offset import offset as geodesic_offset
from ..io.output import check_output, write_bytes
from ..shape import read
from ..vector.offset import offset as _offset
from . import main
from .options import (
    angle,
    distance_option,
    ellipsoid_option,
    metres,
    parse_ellipsoid,
    radius_option,
)


@main.command("offset")
@click.argument("input", metavar="INPUT")
@distance_option
@radius_option
@ellipsoid_option
@click.option(
    "-o", "--output", default="-", show_default=True, help="Output GeoJSON file, - for stdout."
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
def offset_cmd(input, distance, radius, ellipsoid, output, tolerance, digits, raw, method):
    """Offset the curves and polygons of INPUT (GeoJSON path, or - for stdin).

    With --ellipsoid, DIST is a geodesic length in metres on that ellipsoid (polygon
    edges are geodesics) and the rings are densified until every point of them lies
    within --tolerance of DIST."""
    ell = parse_ellipsoid(ellipsoid)
    if ell is not None:
        if raw or method != "general":
            raise OptionError("--raw and --method paper are for the sphere, not --ellipsoid")
        m, tol = metres(distance), metres(tolerance or "1m")
    else:
        d, tol = angle(distance, radius), angle(tolerance or "1e-6rad", radius)
    check_output(output)  # fail before the work
    shape = read(input)
    if ell is not None:
        feat = geodesic_offset(shape, m, ellipsoid=ell, tolerance=tol).to_geojson(digits=digits)
    else:
        off = _offset(shape, d, radius=1.0)
        feat = off.to_geojson(tolerance=tol, digits=digits, raw=raw, method=method)
    feat["properties"]["distance"] = distance
    text = json.dumps({"type": "FeatureCollection", "features": [feat]})
    write_bytes(output, (text + "\n").encode("utf-8"))
