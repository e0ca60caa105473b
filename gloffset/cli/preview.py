"""``gloffset preview``: the region on an orthographic globe, as a PNG (one GL pass over
the cube maps; :mod:`gloffset.raster.globe`)."""

from __future__ import annotations

import click

from ..errors import OptionError
from ..io.output import check_output
from ..io.png import write_animation, write_image
from ..raster.globe import GlobeStyle, globe
from ..shape import read
from . import main
from .options import angle, distance_option, input_options, radius_option


def _center(text: str | None):
    if text is None:
        return None
    try:
        lon, lat = (float(v) for v in text.split(","))
    except ValueError:
        raise OptionError(f"--center is LON,LAT in degrees, got {text!r}") from None
    if not (-180.0 <= lon <= 180.0 and -90.0 <= lat <= 90.0):
        raise OptionError(f"--center {text!r} is not a longitude and latitude")
    return lon, lat


@main.command("preview")
@click.argument("input", metavar="INPUT")
@distance_option
@radius_option
@input_options
@click.option("-o", "--output", required=True, help="Output PNG file (- for stdout).")
@click.option("--center", default=None, metavar="LON,LAT", help="The centre of the view.")
@click.option("--size", type=int, default=1024, show_default=True, help="Image side in pixels.")
@click.option("--fill", default=GlobeStyle.fill, show_default=True, help="Region colour.")
@click.option("--ocean", default=GlobeStyle.ocean, show_default=True, help="Sphere colour.")
@click.option("--input-color", default=GlobeStyle.input_color, show_default=True)
@click.option("--background", default=GlobeStyle.background, show_default=True)
@click.option("--graticule", type=float, default=15.0, show_default=True, help="Degrees; 0: none.")
@click.option("--graticule-color", default=GlobeStyle.grid_color, show_default=True)
@click.option("--shading", type=float, default=0.6, show_default=True, help="0 (flat) to 1.")
@click.option(
    "--spin",
    type=click.IntRange(1, 3600),
    default=None,
    help="Write N frames of the globe turning once round: an animated PNG, or a GIF (.gif).",
)
def preview_cmd(
    input, distance, radius, layer, where, densify, output, center, size, fill, ocean, input_color,
    background, graticule, graticule_color, shading, spin,
):  # fmt: skip
    """Draw the region within DIST of INPUT on an orthographic globe (a PNG), sampled from
    the cube-map faces that 'render --grid cube' writes, in one GL pass; with --spin, an
    animation of the globe turning (APNG, or GIF for a .gif name)."""
    angle(distance, radius)  # fail before the work
    style = GlobeStyle(fill, ocean, input_color, background, graticule_color, graticule, shading)
    style.uniforms()
    check_output(output)
    shape = read(input, layer=layer, where=where, densify=densify)
    img = globe(
        shape, distance, size=size, center=_center(center), style=style,
        radius=radius, spin=spin,
    )  # fmt: skip
    if spin is None:
        write_image(img, output)
    else:
        write_animation(img, output)
