"""``gloffset field``: a raster of the signed distance to the curves of INPUT (a distance
field, :func:`gloffset.distance_field`): a float32 GeoTIFF or ``.npy`` in metres, or six
cube-map faces."""

from __future__ import annotations

import io
from pathlib import Path

import click
import numpy as np

from ..errors import OptionError, OutputError
from ..grids import FACE_NAMES, Cube, Equirect, Projected
from ..io.georef import Georef, check_geotiff, write_geotiff
from ..io.output import check_output, refuse_stdout, write_bytes
from ..raster.field import check_field_grid, distance_field, ellipsoid_refusal
from ..shape import read
from . import main
from .options import (
    angle,
    choice_option,
    crs_option,
    input_options,
    parse_bounds,
    parse_ellipsoid,
    parse_face,
    parse_size,
    progress_bar,
    projected_georef,
    projected_grid,
    radius_option,
    size_options,
)

#: What a field GeoTIFF says of its values (its DESCRIPTION tag).
DESCRIPTION = (
    "gloffset signed distance field: great-circle distance in metres from each pixel centre "
    "to the curves of the input, negative inside its polygons (their union), positive "
    "outside; lines and points unsigned"
)
#: What it adds with --max-distance (the MAX_DISTANCE tag holds the value in metres).
CLAMPED = (
    "; clamped to -MAX_DISTANCE..+MAX_DISTANCE (-MAX_DISTANCE: at least that far inside, "
    "+MAX_DISTANCE: at least that far outside), so the region at a distance d with "
    "|d| < MAX_DISTANCE is v <= d (v < d for d < 0)"
)

_FORMATS = (".tif", ".tiff", ".npy")


def _format(output: str, grid_kind: str) -> str:
    """The output kind: ``"tif"``, ``"npy"`` or, for a cube, ``"folder"``."""
    name = str(output).lower()
    if grid_kind == "cube":
        refuse_stdout(output, "--grid cube writes six .npy faces into a folder")
        if name.endswith(_FORMATS):
            raise OptionError(
                f"-o {str(output)!r}: --grid cube writes six .npy faces into a folder; give a "
                "folder name (faces/), not a file name"
            )
        if Path(output).exists() and not Path(output).is_dir():
            raise OutputError(f"cannot create folder {str(output)!r}: a file is in the way")
        return "folder"
    if not name.endswith(_FORMATS):
        raise OptionError(f"-o {output!r}: a field is written as NAME.tif or NAME.npy")
    check_output(output)  # fail before the work
    if name.endswith(".npy"):
        return "npy"
    check_geotiff()  # rasterio is there
    return "tif"


@main.command("field")
@click.argument("input", metavar="INPUT")
@radius_option
@click.option(
    "--grid",
    "grid_kind",
    type=click.Choice(["equirect", "cube"]),
    default="equirect",
    show_default=True,
    help="equirect: one raster; cube: OUTPUT is a folder of px nx py ny pz nz .npy faces.",
)
@size_options
@crs_option
@click.option(
    "--max-distance",
    "max_distance",
    default=None,
    metavar="DIST",
    help="Clamp the field to +-DIST (e.g. 500km): faster; -DIST and +DIST beyond it, "
    "inside and outside.",
)
@click.option(
    "-o",
    "--output",
    required=True,
    help="NAME.tif (float32 GeoTIFF, EPSG:4326; NAME.cog.tif a Cloud Optimized one) or "
    "NAME.npy (float32); with --grid cube a folder.",
)
@click.option(
    "--ellipsoid",
    default=None,
    metavar="NAME|A,F",
    help="Refused with the reason: fields are on the sphere of --radius (see the docs).",
)
@choice_option(
    "--backend",
    choices=("gpu", "cpu"),
    help="Where each pixel's nearest arcs are found (the values are the same, bit for bit).",
)
@input_options
def field_cmd(
    input,
    radius,
    ellipsoid,
    grid_kind,
    size,
    bounds,
    crs,
    max_distance,
    output,
    backend="gpu",
    layer=None,
    where=None,
    densify=None,
):
    """Write the signed distance field of INPUT: the great-circle distance in metres from
    each pixel centre to its curves, negative inside its polygons (row 0 north).

    One field answers every distance: the region at distance d is where the field is at
    most d. Values are exact float64 distances rounded to float32. With --crs the raster
    is in that projected CRS (+inf where a pixel has no lon/lat)."""
    if ellipsoid is not None:
        parse_ellipsoid(ellipsoid)  # an unknown one is named as such
        raise OptionError(ellipsoid_refusal(ellipsoid))
    if crs is not None and grid_kind == "cube":
        raise OptionError("--crs does not apply to --grid cube")
    kind = _format(output, grid_kind)
    grid: Cube | Equirect | Projected
    if crs is not None:
        grid = projected_grid(crs, size, bounds)
    elif grid_kind == "cube":
        if bounds is not None:
            raise OptionError("--bounds does not apply to --grid cube")
        grid = Cube(parse_face(size or "1024"))
    else:
        w, h = parse_size(size or "4096x2048")
        grid = Equirect(w, h, parse_bounds(bounds))
    check_field_grid(grid)  # not too large
    m = None
    if max_distance is not None:
        m = angle(max_distance, radius) * radius
        if not m > 0.0:
            raise OptionError(f"--max-distance must be a positive distance, got {max_distance!r}")
    shape = read(input, layer=layer, where=where, densify=densify)
    bar = progress_bar(
        total=1,
        unit="px",
        unit_scale=True,
        mininterval=0.1,
        bar_format="{percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} px [{elapsed}<{remaining}]",
    )

    def progress(done: int, total: int) -> None:
        assert bar is not None  # passed on with a bar only
        bar.total = total
        bar.update(done - bar.n)

    try:
        field = distance_field(
            shape,
            grid,
            max_distance=m,
            radius=radius,
            progress=progress if bar is not None else None,
            backend=backend,
        )
    finally:
        if bar is not None:
            bar.close()
    if kind == "folder":
        folder = Path(output)
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(f"cannot create folder {output!r}: {exc.strerror}") from None
        for k, name in enumerate(FACE_NAMES):
            _write_npy(folder / f"{name}.npy", field.values[k])
    elif kind == "npy":
        _write_npy(output, field.values)
    else:
        # the values as the .npy has them: clamped to +-m, so that the sign (and with it
        # every threshold within m) survives beyond m
        cog = str(output).lower().endswith((".cog.tif", ".cog.tiff"))
        desc = DESCRIPTION if m is None else DESCRIPTION + CLAMPED
        if isinstance(grid, Projected):
            ref = projected_georef(grid, desc)
        else:
            assert isinstance(grid, Equirect)  # a cube goes to a folder (_format)
            ref = Georef(grid.transform(), description=desc)
        tags = None if m is None else {"MAX_DISTANCE": repr(m)}
        write_geotiff(output, field.values, ref, cog=cog, tags=tags)


def _write_npy(target, values: np.ndarray) -> None:
    buf = io.BytesIO()
    np.save(buf, values)
    write_bytes(target, buf.getvalue())
