"""``gloffset render``: a PNG of the offset region on an equirectangular grid."""

from __future__ import annotations

import sys
import time

import click

from ..errors import GloffsetError
from ..grids import Equirect
from ..io.png import parse_color, write_classes, write_mask
from ..render import render as _render
from ..shape import read
from . import main
from .options import angle, distance_option, radius_option


class OptionError(GloffsetError, ValueError):
    """A command-line option has a bad value."""


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise OptionError(f"--size must be WIDTHxHEIGHT, e.g. 4096x2048, got {text!r}") from None
    return w, h


def _bounds(text: str | None) -> tuple:
    if text is None:
        return (-180.0, -90.0, 180.0, 90.0)
    try:
        vals = tuple(float(v) for v in text.split(","))
    except ValueError:
        vals = ()
    if len(vals) != 4:
        raise OptionError(f"--bounds must be W,S,E,N in degrees, got {text!r}")
    return vals


@main.command("render")
@click.argument("input", metavar="INPUT")
@distance_option
@radius_option
@click.option(
    "--grid",
    "grid_kind",
    type=click.Choice(["equirect"]),
    default="equirect",
    show_default=True,
    help="Raster grid.",
)
@click.option("--size", default="4096x2048", show_default=True, help="WIDTHxHEIGHT in pixels.")
@click.option(
    "--bounds", default=None, help="W,S,E,N in degrees (W > E crosses 180 deg). Default: the globe."
)
@click.option("-o", "--output", required=True, help="Output PNG file.")
@click.option(
    "--fill", default=None, help="Colour inside the region (RGBA overlay), e.g. '#3070c0cc'."
)
@click.option("--background", default=None, help="Colour outside the region, e.g. '0,0,0,0'.")
@click.option(
    "--classes",
    "classes_level",
    type=int,
    default=None,
    help="Write the classes of this level (contained black, frontier red, outside white).",
)
@click.option("--backend", type=click.Choice(["gpu", "cpu"]), default="gpu", show_default=True)
def render_cmd(
    input,
    distance,
    radius,
    grid_kind,
    size,
    bounds,
    output,
    fill,
    background,
    classes_level,
    backend,
):
    """Render the region within DIST of the curves of INPUT as a PNG (row 0 north)."""
    d = angle(distance, radius)
    for colour in (fill, background):
        if colour is not None:
            parse_color(colour)  # fail before the work
    w, h = _size(size)
    grid = Equirect(w, h, _bounds(bounds))
    shape = read(input)
    show = sys.stderr.isatty()
    t0 = time.perf_counter()

    def progress(level, classes):
        if show:
            frontier = int((classes == 1).sum())
            click.echo(
                f"\rlevel {level + 1}/{grid.n_levels}: {classes.shape[1]}x{classes.shape[0]}, "
                f"{frontier} frontier cells, {time.perf_counter() - t0:.2f} s",
                err=True,
                nl=False,
            )

    if classes_level is not None:
        classes = _render(
            shape,
            d,
            grid,
            radius=1.0,
            out="classes",
            level=classes_level,
            callback=progress,
            backend=backend,
        )
        write_classes(classes, output)
    else:
        mask = _render(shape, d, grid, radius=1.0, callback=progress, backend=backend)
        write_mask(mask, output, fill=fill, background=background)
    if show:
        click.echo("", err=True)


@main.command("info")
def info_cmd():
    """Print the OpenGL device gloffset renders with, and its limits."""
    from ..gl.context import context_info

    for key, val in context_info().items():
        click.echo(f"{key}: {val}")
