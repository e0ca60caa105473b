"""``gloffset tiles``: a tile pyramid (MBTiles, PMTiles or XYZ directory) of the region, web
mercator or another OGC TileMatrixSet (``--tms``)."""

from __future__ import annotations

import bisect
import itertools
import time
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import click

from ..io.output import refuse_stdout
from ..shape import read
from ..tiles.store.tilestore import TILE_FILES, check_tile_output
from ..tiles.tiling import TileProgress, parse_zooms
from ..tiles.tiling.driver import PyramidOptions, check_pyramids, pyramid_quad, write_pyramid
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

_OPTIONS = [
    click.argument("input", metavar="INPUT"),
    measure_options(many=True),
    click.option(
        "-z", "--zoom", "zooms", required=True, help="Zoom range MIN-MAX (0..22), e.g. 0-14."
    ),
    click.option(
        "-o",
        "--output",
        required=True,
        help="OUT.mbtiles (MBTiles 1.3), OUT.pmtiles (PMTiles v3, needs the pmtiles package) "
        "or a directory for z/x/y.png tiles (a name without an extension, or ending in /).",
    ),
    fill_options("#3070c0"),
    click.option("--outline", default=None, help="Draw the input curves in this colour."),
    click.option("--outline-width", type=int, default=1, show_default=True, help="In pixels."),
    click.option(
        "--tile-size",
        type=int,
        default=256,
        show_default=True,
        help="Tile side, pixels (a power of two).",
    ),
    click.option(
        "--tms",
        default=None,
        metavar="ID",
        help="The OGC TileMatrixSet of the tiles (default WebMercatorQuad), e.g. WorldCRS84Quad "
        "(two tiles at zoom 0): written to a folder, z/x/y.png with tileMatrixSet.json beside "
        "them.",
    ),
    click.option("--name", default=None, help="Tileset name (default: the output's name)."),
    click.option(
        "--field",
        is_flag=True,
        help="Write distance-field tiles instead (no -d): every tile of the zooms holds the signed "
        "distance in metres at its pixel centres as RGB, metres = R * 65536 + G * 256 + B - "
        "8388608 (MapLibre raster-dem custom encoding; docs/guide/tiles.md).",
    ),
    click.option(
        "--format",
        "tile_format",
        type=click.Choice(["png", "mvt"]),
        default="png",
        show_default=True,
        help="png: raster tiles; mvt: Mapbox Vector Tiles (MVT 2.1, .pbf) of the region's exact "
        "boundary, one layer named after the input (pip install 'gloffset[mvt]').",
    ),
    click.option(
        "--extent",
        type=int,
        default=4096,
        show_default=True,
        help="With --format mvt: tile units across a tile (a power of two).",
    ),
    click.option(
        "--buffer",
        type=int,
        default=64,
        show_default=True,
        help="With --format mvt: tile units kept beyond each side of a tile.",
    ),
    click.option("--resume", is_flag=True, help="Complete an interrupted run (same options)."),
    click.option("--force", is_flag=True, help="Replace an existing output."),
    click.option(
        "--workers",
        type=click.IntRange(min=1),
        default=None,
        help="Render on a local Dask cluster of N worker processes (pip install 'gloffset[dask]'); "
        "the output is the same as with one process.",
    ),
    click.option(
        "--scheduler",
        default=None,
        help="Render on a running Dask cluster (its scheduler address).",
    ),
    input_options,
]


def _tiles_options(f):
    """The arguments and options of ``tiles``, in the order ``--help`` lists them."""
    for option in reversed(_OPTIONS):
        f = option(f)
    return f


@main.command("tiles")
@_tiles_options
def tiles_cmd(**given):
    """Write the tile pyramid of the region within DIST of the curves of INPUT: tiles
    outside the region are skipped, tiles fully inside share one image and are not
    rendered, only tiles on the region's edge are rendered. With --ellipsoid, DIST is a
    geodesic length on that ellipsoid (no --outline, --workers). With --field, the
    tiles are the signed distance field instead, at every distance at once.

    Several distances, -d 10km,50km,127km, write one pyramid per distance from one read
    of INPUT, named by the distance as given: OUT_10km.mbtiles (.pmtiles), ... or, for a
    folder OUT, OUT/10km/z/x/y.png, ...; each the same as the run at that distance alone."""
    g = SimpleNamespace(**given)
    if g.resume and g.force:
        raise click.UsageError("--resume and --force exclude each other")
    if g.tile_format == "mvt":
        return _mvt_tiles(given)
    ctx = click.get_current_context()
    for opt in ("extent", "buffer"):
        if ctx.get_parameter_source(opt) not in (None, *_DEFAULTS):
            raise click.UsageError(f"--{opt} is an option of vector tiles (--format mvt)")
    if g.field:
        return _field_tiles(given)
    if g.distance is None:
        raise click.UsageError("Missing option '-d' / '--distance' (or give --field).")
    ell = parse_ellipsoid(g.ellipsoid)
    # fail before the work
    convert = (lambda t: metres(t)) if ell is not None else (lambda t: angle(t, g.radius))
    texts = [text for text, _ in distance_list(g.distance, convert)]  # as given
    output = g.output
    refuse_stdout(
        output, "a tile pyramid is an .mbtiles or .pmtiles file or a folder of z/x/y.png tiles"
    )
    check_tile_output(output)
    outputs = [output] if len(texts) == 1 else [tile_output(output, t) for t in texts]
    _, zhi = parse_zooms(g.zooms)
    style = TileStyle(g.fill, g.opacity, g.outline, g.outline_width)
    checked = PyramidOptions(size=g.tile_size, style=style, ellipsoid=ell, tms=g.tms)
    for out in outputs:  # the TileMatrixSet against the options and outputs, before the read
        pyramid_quad(checked, out, zhi)
    shape = read(g.input, layer=g.layer, where=g.where, densify=g.densify)
    options = PyramidOptions(
        radius=g.radius,
        size=g.tile_size,
        style=style,
        resume=g.resume,
        overwrite=g.force,
        name=g.name,
        source="stdin" if g.input == "-" else Path(g.input).stem,
        workers=g.workers,
        scheduler=g.scheduler,
        ellipsoid=ell,
        tms=g.tms,
    )
    # every distance and output checked (free, replaced or resumable) before any is written
    check_pyramids(shape, texts, g.zooms, outputs, options)
    _write_pyramids(shape, texts, g.zooms, outputs, options)


def _write_pyramids(shape, texts, zooms, outputs, options: PyramidOptions) -> None:
    """Write the pyramid of each distance (as given) to its output, with a progress bar."""
    bar, progress = _tile_bar()
    options = replace(options, progress=progress)
    try:
        for text, out in zip(texts, outputs):
            if len(texts) > 1:
                click.echo(f"-d {text}: {out}", err=True)
            _say(write_pyramid(shape, text, zooms, out, options))
    finally:
        if bar is not None:
            bar.close()


def _tile_bar():
    """A bar on stderr (where :func:`~.options.show_progress`) and the ``progress`` that
    draws a :class:`~gloffset.tiles.tiling.TileProgress` on it: the share of the time
    done, the zoom, the tiles and the time left; ``(None, None)`` where none is shown.
    The bar is closed with the command, or before by its ``close()``."""
    bar = progress_bar(total=100, bar_format="{percentage:3.0f}%|{bar}| {desc}")
    if bar is None:
        return None, None
    click.get_current_context().call_on_close(bar.close)  # on an error too
    shown = [0.0]

    def progress(p):
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

    return bar, progress


def _field_progress(show, zooms: tuple[int, int], quad=None):
    """A field pyramid's ``progress(done, total)`` (its tiles zoom by zoom) as the
    :class:`~gloffset.tiles.tiling.TileProgress` that ``show`` draws: the zoom of
    tile ``done`` (from the tiles of each zoom of ``quad``, the TileMatrixSet's
    :class:`~gloffset.grids.tms.TmsQuad`, None for web mercator), and the time left at
    the pace of the tiles so far (every tile of a zoom is computed alike); told once at
    the start."""
    from ..tiles.tiling.fieldtiles import matrix_shapes

    zlo, zhi = zooms
    counts = [rows * cols for rows, cols in matrix_shapes(quad, zhi)[zlo:]]
    ends = list(itertools.accumulate(counts))
    t0 = time.perf_counter()

    def progress(done: int, total: int) -> None:
        zoom = min(zlo + bisect.bisect_left(ends, max(done, 1)), zhi)
        seconds = time.perf_counter() - t0
        eta = seconds * (total - done) / done if done else None
        show(TileProgress(zoom, done, total, seconds, eta))

    progress(0, ends[-1])
    return progress


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


#: The options of a raster pyramid that a field pyramid does not take, and why.
_NOT_FOR_FIELD = (
    (("distance",), "a field holds every distance"),
    (("ellipsoid",), "field tiles are distances on the sphere of --radius"),
    (("fill", "opacity", "outline", "outline_width"), "field tiles hold distances, not colours"),
    (("workers", "scheduler"), "field tiles are written in one process"),
    (("extent", "buffer"), "these are options of vector tiles (--format mvt)"),
)


def _field_tiles(given: dict) -> None:
    """``gloffset tiles --field``: the distance-field pyramid
    (:func:`gloffset.tiles.tiling.fieldtiles.field_pyramid`) of the options ``given``;
    an option that only a raster pyramid takes is refused, even given at its default."""
    from ..tiles.tiling.fieldtiles import field_pyramid

    ctx = click.get_current_context()
    for names, why in _NOT_FOR_FIELD:
        for param in (p for p in tiles_cmd.params if p.name in names):
            if ctx.get_parameter_source(param.name) not in (None, *_DEFAULTS):
                raise click.UsageError(f"--field takes no {param.opts[0]}: {why}")
    output = given["output"]
    refuse_stdout(output, "field tiles are an .mbtiles or .pmtiles file or a folder")
    check_tile_output(output)
    zrange = parse_zooms(given["zooms"])
    quad = pyramid_quad(
        PyramidOptions(size=given["tile_size"], tms=given["tms"]), output, zrange[1]
    )
    shape = read(
        given["input"], layer=given["layer"], where=given["where"], densify=given["densify"]
    )
    t0 = time.perf_counter()
    bar, show = _tile_bar()
    n = field_pyramid(
        shape,
        given["zooms"],
        output,
        radius=given["radius"],
        size=given["tile_size"],
        name=given["name"],
        source="stdin" if given["input"] == "-" else Path(given["input"]).stem,
        overwrite=given["force"],
        resume=given["resume"],
        progress=None if show is None else _field_progress(show, zrange, quad),
        tms=given["tms"],
    )
    if bar is not None:
        bar.close()
    click.echo(f"{n:,} field tiles written; {time.perf_counter() - t0:.1f} s", err=True)


_DEFAULTS = (click.core.ParameterSource.DEFAULT, click.core.ParameterSource.DEFAULT_MAP)


def _mvt_tiles(given: dict) -> None:
    """``gloffset tiles --format mvt``: vector tile pyramids
    (:func:`gloffset.mvt.pyramid.mvt_pyramid`), one per distance, every distance and
    output checked before any is written."""
    from ..errors import OptionError
    from ..mvt.pyramid import mvt_pyramid
    from ..mvt.tile import check_mvt_options
    from ..tiles.store.tilestore import check_store

    g = SimpleNamespace(**given)
    for opt, bad in (
        ("--field", g.field),
        ("--tms", g.tms not in (None, "WebMercatorQuad")),
        ("--ellipsoid", g.ellipsoid is not None),
        ("--outline", g.outline is not None),
        ("--resume", g.resume),
        ("--workers", g.workers is not None),
        ("--scheduler", g.scheduler is not None),
    ):
        if bad:
            raise click.UsageError(f"--format mvt takes no {opt}")
    if g.distance is None:
        raise click.UsageError("Missing option '-d' / '--distance'.")
    output = g.output
    suffix = Path(str(output)).suffix.lower()
    if suffix and suffix not in TILE_FILES and not str(output).endswith("/"):
        raise OptionError(
            f"{output!r}: --format mvt writes vector tiles to NAME.mbtiles, NAME.pmtiles or a "
            f"folder of z/x/y.pbf tiles, not to a {suffix!r} file"
        )
    check_mvt_options(g.extent, g.buffer)
    many = distance_list(g.distance, lambda t: angle(t, g.radius))
    refuse_stdout(output, "vector tiles are an .mbtiles or .pmtiles file or a folder")
    check_tile_output(output)
    outputs = [output] if len(many) == 1 else [tile_output(output, t) for t, _ in many]
    zlo, zhi = parse_zooms(g.zooms)
    for out in outputs:  # every output free (or replaced) before any is written
        check_store(out, overwrite=g.force)
    shape = read(g.input, layer=g.layer, where=g.where, densify=g.densify)
    layer = "offset" if g.input == "-" else Path(g.input).stem
    for (text, _), out in zip(many, outputs):
        if len(many) > 1:
            click.echo(f"-d {text}: {out}", err=True)
        stats = mvt_pyramid(
            shape,
            text,
            (zlo, zhi),
            out,
            radius=g.radius,
            extent=g.extent,
            buffer=g.buffer,
            layer=layer,
            name=g.name,
            overwrite=g.force,
        )
        click.echo(
            f"{stats.written:,} vector tiles written ({stats.frontier:,} with boundary, "
            f"{stats.inside:,} inside); {stats.seconds:.1f} s",
            err=True,
        )
