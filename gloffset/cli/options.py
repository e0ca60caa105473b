"""Options shared by several subcommands."""

from __future__ import annotations

import click

from ..units import EARTH_RADIUS, parse_distance


def distance_option(f=None, *, default: str | None = None):
    """``-d/--distance``, required unless a ``default`` is given (``@distance_option`` or
    ``@distance_option(default="0")``)."""

    def decorate(f):
        # no default=None for a required option: recent click (8.5) takes an explicit None
        # as a default value and no longer reports the option as missing
        given = {"default": default, "show_default": True} if default is not None else {}
        return click.option(
            "-d",
            "--distance",
            required=default is None,
            metavar="DIST",
            help="Offset distance: 500m, 127km, 0.02rad, 1.5deg (a bare number is metres). "
            "Negative shrinks polygons.",
            **given,
        )(f)

    return decorate(f) if f is not None else decorate


def radius_option(f):
    return click.option(
        "--radius",
        type=float,
        default=EARTH_RADIUS,
        show_default=True,
        help="Sphere radius in metres.",
    )(f)


def angle(text: str, radius: float) -> float:
    """A CLI distance as an angle in radians (raises InvalidDistanceError on bad input)."""
    return parse_distance(text, radius)


def input_options(f):
    """``--layer`` and ``--where``: which layer and features of a vector file to read."""
    f = click.option(
        "--where",
        default=None,
        metavar="SQL",
        help="Read only the features of a vector file that match this attribute filter "
        "(OGR SQL), e.g. \"continent = 'Africa'\".",
    )(f)
    return click.option(
        "--layer",
        default=None,
        help="The layer of a vector file with several (a name or a 0-based index).",
    )(f)
