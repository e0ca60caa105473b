"""``gloffset tiles``: a tile pyramid (MBTiles, PMTiles or XYZ directory) of the region, web
mercator or another OGC TileMatrixSet (``--tms``)."""

from __future__ import annotations

import time
from pathlib import Path

import click

from ..io.output import refuse_stdout
from ..shape import read
from ..tiles.store.tilestore import TILE_FILES, check_tile_output
from ..tiles.tiling import parse_zooms
from ..tiles.tiling.driver import PyramidOptions, pyramid_quad, write_pyramid
from ..tiles.tiling.tilepaint import TileStyle
from . import main
from .options import (
    angle,
    distance_list,
    fill_options,
    input_options,
    measure_options,
    metres,
    parse_ellipsoid,
    progress_bar,
)


@main.command("tiles")
@click.argument("input", metavar="INPUT")
@measure_options(many=True)
@click.option("-z", "--zoom", "zooms", required=True, help="Zoom range MIN-MAX (0..22), e.g. 0-14.")
@click.option(
    "-o",
    "--output",
    required=True,
    help="OUT.mbtiles (MBTiles 1.3), OUT.pmtiles (PMTiles v3, needs the pmtiles package) "
    "or a directory for z/x/y.png tiles (a name without an extension, or ending in /).",
)
@fill_options("#3070c0")
@click.option("--outline", default=None, help="Draw the input curves in this colour.")
@click.option("--outline-width", type=int, default=1, show_default=True, help="In pixels.")
@click.option(
    "--tile-size",
    type=int,
    default=256,
    show_default=True,
    help="Tile side, pixels (a power of two).",
)
@click.option(
    "--tms",
    default=None,
    metavar="ID",
    help="The OGC TileMatrixSet of the tiles (default WebMercatorQuad), e.g. WorldCRS84Quad "
    "(two tiles at zoom 0): written to a folder, z/x/y.png with tileMatrixSet.json beside them.",
)
@click.option("--name", default=None, help="Tileset name (default: the output's name).")
@click.option(
    "--field",
    is_flag=True,
    help="Write distance-field tiles instead (no -d): every tile of the zooms holds the signed "
    "distance in metres at its pixel centres as RGB, metres = R * 65536 + G * 256 + B - "
    "8388608 (MapLibre raster-dem custom encoding; docs/guide/tiles.md).",
)
@click.option("--resume", is_flag=True, help="Complete an interrupted run (same options).")
@click.option("--force", is_flag=True, help="Replace an existing output.")
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    help="Render on a local Dask cluster of N worker processes (pip install 'gloffset[dask]'); "
    "the output is the same as with one process.",
)
@click.option(
    "--scheduler", default=None, help="Render on a running Dask cluster (its scheduler address)."
)
@input_options
def tiles_cmd(
    input,
    distance,
    radius,
    ellipsoid,
    zooms,
    output,
    fill,
    opacity,
    outline,
    outline_width,
    tile_size,
    tms,
    name,
    field,
    resume,
    force,
    workers,
    scheduler,
    layer=None,
    where=None,
    densify=None,
):
    """Write the tile pyramid of the region within DIST of the curves of INPUT: tiles
    outside the region are skipped, tiles fully inside share one image and are not
    rendered, only tiles on the region's edge are rendered. With --ellipsoid, DIST is a
    geodesic length on that ellipsoid (no --outline, --workers). With --field, the
    tiles are the signed distance field instead, at every distance at once.

    Several distances, -d 10km,50km,127km, write one pyramid per distance from one read
    of INPUT, named by the distance as given: OUT_10km.mbtiles (.pmtiles), ... or, for a
    folder OUT, OUT/10km/z/x/y.png, ...; each the same as the run at that distance alone."""
    if field:
        return _field_tiles(
            input, radius, ellipsoid, zooms, output, tile_size, name, force, locals()
        )
    if distance is None:
        raise click.UsageError("Missing option '-d' / '--distance' (or give --field).")
    ell = parse_ellipsoid(ellipsoid)
    # fail before the work
    many = distance_list(distance, lambda t: metres(t) if ell is not None else angle(t, radius))
    refuse_stdout(
        output, "a tile pyramid is an .mbtiles or .pmtiles file or a folder of z/x/y.png tiles"
    )
    check_tile_output(output)
    outputs = [output] if len(many) == 1 else [tile_output(output, t) for t, _ in many]
    _, zhi = parse_zooms(zooms)
    style = TileStyle(fill, opacity, outline, outline_width)
    checked = PyramidOptions(size=tile_size, style=style, ellipsoid=ell, tms=tms)
    for out in outputs:  # the TileMatrixSet against the options and outputs
        pyramid_quad(checked, out, zhi)
    if resume and force:
        raise click.UsageError("--resume and --force exclude each other")
    shape = read(input, layer=layer, where=where, densify=densify)
    bar = progress_bar(total=100, bar_format="{percentage:3.0f}%|{bar}| {desc}")
    shown = [0.0]

    def progress(p):
        assert bar is not None  # passed on with a bar only
        # the bar is the share of the time (p.fraction), the ETA the library's estimate
        bar.n = round(100.0 * p.fraction, 1)
        left = "?" if p.eta is None else bar.format_interval(p.eta)
        total = f"{p.total:,}" if p.done == p.total else f"~{p.total:,}"
        bar.set_description_str(
            f"z{p.zoom}, {p.done:,}/{total} tiles [{bar.format_interval(p.seconds)}<{left}]",
            refresh=False,
        )
        now = time.monotonic()
        if now - shown[0] >= 0.1 or p.done == p.total:
            shown[0] = now
            bar.refresh()

    options = PyramidOptions(
        radius=radius,
        size=tile_size,
        style=style,
        resume=resume,
        overwrite=force,
        name=name,
        source="stdin" if input == "-" else Path(input).stem,
        progress=progress if bar is not None else None,
        workers=workers,
        scheduler=scheduler,
        ellipsoid=ell,
        tms=tms,
    )
    try:
        for (text, _), out in zip(many, outputs):
            if len(many) > 1:
                click.echo(f"-d {text}: {out}", err=True)
            stats = write_pyramid(shape, text, zooms, out, options)  # text: as given
            _say(stats)
    finally:
        if bar is not None:
            bar.close()


def tile_output(output, text: str) -> str:
    """The pyramid of distance ``text`` among several: ``out.pmtiles`` ->
    ``out_10km.pmtiles``; a folder ``out`` -> ``out/10km`` (its tiles
    ``out/10km/z/x/y.png``)."""
    path = Path(output)
    if path.suffix.lower() in TILE_FILES:
        return str(path.with_name(f"{path.stem}_{text}{path.suffix}"))
    return str(path / text)


def _say(stats) -> None:
    """What became of each tile handled (the progress counts every one)."""
    click.echo(
        f"{stats.handled:,} tiles handled: {stats.written:,} tiles written "
        f"({stats.rendered - stats.empty:,} rendered, {stats.inside:,} inside without "
        f"rendering, {stats.painted:,} outlined), {stats.empty:,} rendered empty and not "
        f"written, {stats.present:,} already present; {stats.outside:,} outside skipped; "
        f"{stats.seconds:.1f} s",
        err=True,
    )


# -d is required unless --field is given (checked in the command)
next(p for p in tiles_cmd.params if p.name == "distance").required = False


def _field_tiles(input, radius, ellipsoid, zooms, output, size, name, force, given) -> None:
    """``gloffset tiles --field``: the distance-field pyramid
    (:func:`gloffset.tiles.tiling.fieldtiles.field_pyramid`)."""
    from ..tiles.tiling.fieldtiles import field_pyramid

    for opt, bad in (
        ("-d", given["distance"] is not None),
        ("--ellipsoid", ellipsoid is not None),
        ("--outline", given["outline"] is not None),
        ("--resume", given["resume"]),
        ("--workers", given["workers"] is not None),
        ("--scheduler", given["scheduler"] is not None),
    ):
        if bad:
            raise click.UsageError(f"--field takes no {opt}: a field holds every distance")
    refuse_stdout(output, "field tiles are an .mbtiles or .pmtiles file or a folder")
    check_tile_output(output)
    _, zhi = parse_zooms(zooms)
    pyramid_quad(PyramidOptions(size=size, tms=given["tms"]), output, zhi)
    shape = read(input, layer=given["layer"], where=given["where"], densify=given["densify"])
    t0 = time.perf_counter()
    n = field_pyramid(
        shape,
        zooms,
        output,
        radius=radius,
        size=size,
        name=name,
        source="stdin" if input == "-" else Path(input).stem,
        overwrite=force,
        tms=given["tms"],
    )
    click.echo(f"{n:,} field tiles written; {time.perf_counter() - t0:.1f} s", err=True)
