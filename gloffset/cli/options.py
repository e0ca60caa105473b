"""Options shared by several subcommands."""

from __future__ import annotations

import click

from ..units import EARTH_RADIUS, parse_distance


def distance_option(f=None, *, default: str | None = None):
    """``-d/--distance``, required unless a ``default`` is given (``@distance_option`` or
    ``@distance_option(default="0")``)."""

    def decorate(f):
        return click.option(
            "-d",
            "--distance",
            required=default is None,
            default=default,
            show_default=default is not None,
            metavar="DIST",
            help="Offset distance: 500m, 127km, 0.02rad, 1.5deg (a bare number is metres). "
            "Negative shrinks polygons.",
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
