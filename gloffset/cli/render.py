"""``gloffset render``: a PNG of the offset region on an equirectangular grid, or six
cube-map faces (of a vector INPUT, or of a rasterized curve with ``--from-raster``)."""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import click
import numpy as np

from ..errors import InputFormatError, OptionError, OutputError
from ..grids import FACE_NAMES, Cube, CubeFace, Equirect, InvalidGridError, Projected
from ..io.georef import Georef, read_geotiff
from ..io.output import check_output, refuse_stdout
from ..io.png import Placement, image_format, parse_color, read_mask, write_classes, write_mask
from ..raster.rasterized import CONTAINED
from ..raster.render import render as _render
from ..shape import read
from . import main
from .options import (
    angle,
    choice_option,
    crs_option,
    distance_list,
    fill_options,
    input_options,
    measure_options,
    metres,
    parse_ellipsoid,
    projected_georef,
    projected_grid,
    size_options,
)
from .options import parse_bounds as _bounds
from .options import parse_face as _face
from .options import parse_size as _size

#: The former name of :class:`~gloffset.errors.InputFormatError` (cube-face mask PNGs that
#: are missing, not square, or of different sizes), kept so that ``except CubeFacesError``
#: works.
CubeFacesError = InputFormatError


@dataclass(frozen=True)
class _Args:
    """The options of ``render`` as click passes them."""

    input: str | None
    distance: Any  # as given (str): the library converts it once
    radius: float
    ellipsoid: str | None
    grid_kind: Any  # "equirect", "cube" or ("crs", CRS)
    size: str | None
    bounds: str | None
    crs: str | None
    output: str
    fill: str | None
    opacity: float
    background: str | None
    classes_level: int | None
    bands: bool
    backend: str
    from_raster: str | None
    mask_only: bool
    cog: bool
    no_worldfile: bool
    layer: str | None = None
    where: str | None = None
    densify: str | None = None

    def read_options(self) -> dict:
        return dict(layer=self.layer, where=self.where, densify=self.densify)


def _render_options(f):
    """The arguments and options of ``render``, in the order ``--help`` lists them."""
    for option in reversed(_OPTIONS):
        f = option(f)
    return f


_OPTIONS = [
    click.argument("input", metavar="INPUT", required=False),
    measure_options(many=True),
    choice_option(
        "--grid",
        "grid_kind",
        choices=("equirect", "cube"),
        help="equirect: one image; cube: OUTPUT is a folder of px nx py ny pz nz PNGs.",
    ),
    size_options,
    crs_option,
    click.option(
        "-o",
        "--output",
        required=True,
        help="Output image: PNG, or TIFF if it ends in .tif/.tiff; - for standard output (PNG). "
        "With --grid cube: a folder.",
    ),
    click.option(
        "--from-raster",
        "from_raster",
        default=None,
        metavar="MASK.png|DIR",
        help="Offset a rasterized curve on the equirect grid of --bounds instead of INPUT (paper "
        "Sec. 5); writes the classes picture (or with --mask a mask). The mask is a grey image "
        "(curve: pixels at least half white, >= 128) or an image with transparency (curve: pixels "
        "at least half opaque, alpha >= 128); colour images are refused. A PNG covers --bounds; "
        "without --bounds only a 2:1 image is taken as the whole globe (any other needs "
        "--bounds). A GeoTIFF has its own lon/lat transform. With --grid cube: a folder of six "
        "face PNGs px nx py ny pz nz, and OUTPUT a folder of six PNGs.",
    ),
    click.option(
        "--mask",
        "--mask-only",
        "mask_only",
        is_flag=True,
        help="With --from-raster: a plain mask as render writes for INPUT, 255 for the cells "
        "the offset contains and 0 elsewhere (--fill, --background and --opacity style it), "
        "instead of the classes picture.",
    ),
    fill_options(
        None,
        "the region (an RGBA image; with neither --fill nor --background a grey mask, "
        "255 inside, 0 outside)",
    ),
    click.option("--background", default=None, help="Colour outside the region, e.g. '0,0,0,0'."),
    click.option(
        "--classes",
        "classes_level",
        type=int,
        default=None,
        help="Write the classes of this level (contained black, frontier red, outside white): "
        "a coarser level than the output's is written at its own size (each cell one pixel; "
        "stderr says which), without georeference.",
    ),
    click.option(
        "--bands",
        is_flag=True,
        help="With -d D1,D2,...: one grey image instead of one mask per distance, each pixel the "
        "index of the smallest distance whose region holds it (0: none, k: the k-th smallest "
        "distance; its Description says which is which).",
    ),
    choice_option("--backend", choices=("gpu", "cpu")),
    click.option(
        "--cog",
        is_flag=True,
        help="With -o NAME.tif: a Cloud Optimized GeoTIFF (also chosen by NAME.cog.tif).",
    ),
    click.option(
        "--no-worldfile",
        "no_worldfile",
        is_flag=True,
        help="Write no world file (.pgw) and .prj beside a PNG.",
    ),
    input_options,
]


@main.command("render")
@_render_options
def render_cmd(**given):
    """Render the region within DIST of the curves of INPUT as a PNG or TIFF (row 0 north),
    or as six cube-map faces px nx py ny pz nz that load straight into a GL or three.js
    cube texture (sampled with the Earth-frame direction: x to 0N 0E, z to the north pole).

    Equirect images are georeferenced (EPSG:4326): a .tif is a tiled, compressed GeoTIFF
    (rasterio: pip install 'gloffset[geo]'), a .png gets a world file (.pgw, pixel centres)
    and a .prj beside it. With --crs (e.g. EPSG:3031 --bounds XMIN,YMIN,XMAX,YMAX) the
    image is in that projected CRS, georeferenced in it.

    Several distances, -d 10km,50km,127km, write one mask per distance, named by the
    distance as given (out_10km.png, out_50km.png, ...; with --grid cube the folders
    out_10km, ...), each the same as the run at that distance alone; or with --bands one
    image of the distance bands."""
    o = _Args(**given)
    o = replace(o, grid_kind=_with_crs(o.grid_kind, o.crs, o.from_raster))
    ell = parse_ellipsoid(o.ellipsoid)
    many = distance_list(o.distance, lambda t: metres(t) if ell is not None else angle(t, o.radius))
    if len(many) > 1 or o.bands:
        if o.from_raster is not None or o.classes_level is not None or o.mask_only:
            raise OptionError(
                "several distances (or --bands) render masks of vector INPUT: no "
                "--from-raster, --classes or --mask"
            )
        return _many_cmd(o, many, ell)
    if ell is not None and o.from_raster is None and o.classes_level is not None:
        raise OptionError("--ellipsoid renders masks of vector INPUT: no --classes")
    cog = _check_output(o.output, o.grid_kind, o.cog)
    style = _checked_style(o.fill, o.opacity, o.background)  # fail before the work
    if o.from_raster is None:
        return _vector_cmd(o, ell, cog)
    if o.input is not None or o.size is not None:
        raise OptionError("--from-raster takes no INPUT or --size (the PNGs' size)")
    raster_opts = (o.classes_level, o.backend, o.mask_only, style)
    where = (o.grid_kind, o.bounds, o.output, cog, not o.no_worldfile)
    return _from_raster_cmd(o.from_raster, (many[0][0], o.radius, ell), where, raster_opts)


def _vector_cmd(o: _Args, ell, cog: bool) -> None:
    """``render`` of one distance of vector INPUT: the mask, or the classes of a level."""
    if o.input is None:
        raise OptionError("give an INPUT file (or - for stdin), or --from-raster MASK.png")
    if o.mask_only:
        raise OptionError("--mask is for --from-raster: render writes a mask of INPUT already")
    grid, levels = _grid(o.grid_kind, o.size, o.bounds)
    _say_level_size(grid, o.classes_level)
    shape = read(o.input, **o.read_options())
    show = sys.stderr.isatty()
    t0 = time.perf_counter()

    def progress(level, classes):
        if show:
            frontier = int((classes == 1).sum())
            click.echo(
                f"\rlevel {level + 1}/{levels}: {classes.shape[1]}x{classes.shape[0]}, "
                f"{frontier} frontier cells, {time.perf_counter() - t0:.2f} s",
                err=True,
                nl=False,
            )

    out = "classes" if o.classes_level is not None else "mask"
    result = _render(
        shape,
        o.distance,  # as given: the library converts it once
        grid,
        radius=o.radius,
        out=out,
        level=o.classes_level,
        callback=progress if ell is None else None,
        backend=o.backend,
        ellipsoid=ell,
    )
    if o.grid_kind == "cube":
        folder = _out_folder(o.output)
        targets = [(folder / f"{name}.png", result[k]) for k, name in enumerate(FACE_NAMES)]
    else:
        targets = [(Path(o.output), result)]
    styled = out == "mask" and (o.fill, o.background, o.opacity) != (None, None, 1.0)
    what = "styled" if styled else out
    place = None if o.grid_kind == "cube" else _placement(grid, cog, not o.no_worldfile, what)
    if out == "classes" and place is not None and o.classes_level != grid.n_levels - 1:
        place = None  # a coarser level's classes are not the grid's pixels
    for path, img in targets:
        if out == "classes":
            write_classes(img, path, place=place)
        else:
            write_mask(
                img, path, fill=o.fill, opacity=o.opacity, background=o.background, place=place
            )
    if show:
        click.echo("", err=True)


def named(output, text: str) -> str:
    """The output of distance ``text`` among several: ``out.png`` -> ``out_10km.png``
    (``out.cog.tif`` -> ``out_10km.cog.tif``; a folder ``out`` -> ``out_10km``)."""
    path = Path(output)
    name = path.name
    low = name.lower()
    for ext in (".cog.tif", ".cog.tiff", ".tif", ".tiff", ".png"):
        if low.endswith(ext):
            stem, suffix = name[: -len(ext)], name[-len(ext) :]
            break
    else:
        stem, suffix = name.rstrip("/"), ""
    return str(path.with_name(f"{stem}_{text}{suffix}"))


def _many_cmd(o: _Args, many, ell) -> None:
    """``render -d D1,D2,...``: the masks of the distances ``many`` (each as given and its
    value) from one read of INPUT (:func:`gloffset.raster.many.render_many`), one file
    per distance or, with ``--bands``, one image of the bands
    (:func:`gloffset.raster.many.mask_bands`); ``ell``: the ellipsoid or None."""
    from ..raster.many import mask_bands, render_many

    input, radius, backend, read_opts = o.input, o.radius, o.backend, o.read_options()
    output, cog, worldfile, bands = o.output, o.cog, not o.no_worldfile, o.bands
    grid_kind, size, bounds = o.grid_kind, o.size, o.bounds
    style = (o.fill, o.opacity, o.background)
    if input is None:
        raise OptionError("give an INPUT file (or - for stdin)")
    if bands and style != (None, 1.0, None):
        raise OptionError("--bands writes distance indices: no --fill, --background, --opacity")
    if len(many) > 1 and not bands:
        refuse_stdout(output, "several distances write one file per distance: give a name")
        if grid_kind != "cube":
            image_format(output)  # the name as given, before the names per distance
        outputs = [named(output, text) for text, _ in many]
    else:
        outputs = [output]
    for out in outputs:
        cog = _check_output(out, grid_kind, cog)
    grid, _ = _grid(grid_kind, size, bounds)
    shape = read(input, **read_opts)
    values = [v for _, v in many]
    show = sys.stderr.isatty()
    if show:
        click.echo(f"rendering {len(many)} distances", err=True)
    texts = [text for text, _ in many]  # as given: the library converts them once
    masks = render_many(shape, texts, grid, radius=radius, backend=backend, ellipsoid=ell)
    if bands:
        image, order = mask_bands(masks, values)
        key = ", ".join(f"{k}={many[i][0]}" for k, i in enumerate(order, start=1))
        desc = (
            "gloffset distance bands: 0 outside every region, k inside the region of the "
            f"k-th smallest distance and of no smaller one: {key}"
        )
        images, what = [image], desc
    else:
        fill, opacity, background = style
        styled = style != (None, 1.0, None)
        images, what = masks, ("styled" if styled else "mask")
    for out, img in zip(outputs, images):
        if grid_kind == "cube":
            folder = _out_folder(out)
            targets = [(folder / f"{name}.png", img[k]) for k, name in enumerate(FACE_NAMES)]
            place = None
        else:
            targets = [(Path(out), img)]
            place = _placement(grid, cog, worldfile, what)
        for path, face in targets:
            if bands:
                write_mask(face, path, place=place)
            else:
                write_mask(
                    face, path, fill=fill, opacity=opacity, background=background, place=place
                )


def _from_raster_cmd(path, measure, where, opts):
    """``render --from-raster``: the options checked, the cube or the equirect offset of
    the mask; ``measure`` is ``(distance as given, radius, ellipsoid)``, ``where``
    ``(grid kind, bounds, output, cog, worldfile)``, ``opts`` ``(level, backend,
    mask_only, style)``."""
    from ..raster.rasterized import RasterOffsetOptions

    distance, radius, ell = measure  # the distance as given: the library converts it once
    grid_kind, bounds, output, *place = where
    level, backend, mask_only, style = opts
    options = RasterOffsetOptions(radius=radius, backend=backend, level=level, ellipsoid=ell)
    if style != (None, 1.0, None) and not mask_only:
        raise OptionError(
            "--fill, --background and --opacity style a mask: with --from-raster add "
            "--mask (the classes picture has its own colours)"
        )
    if grid_kind == "cube":
        if ell is not None:
            raise OptionError("--ellipsoid with --from-raster takes an equirect mask")
        if bounds is not None:
            raise OptionError("--bounds does not apply to --grid cube")
        return _from_raster_cube(path, distance, options, output, mask_only, style)
    if Path(path).is_dir():
        raise OptionError(
            f"--from-raster {path!r} is a folder: add --grid cube to read the six "
            "cube faces px.png nx.png py.png ny.png pz.png nz.png from it"
        )
    return _from_raster(path, distance, options, (bounds, output), mask_only, place, style)


def _check_output(output, grid_kind, cog) -> bool:
    """Check the output options before the work; whether a COG is written."""
    cog = cog or str(output).lower().endswith((".cog.tif", ".cog.tiff"))
    if cog and (grid_kind == "cube" or image_format(output) != "TIFF"):
        raise OptionError("--cog needs an equirect or --crs image written to NAME.tif")
    if grid_kind == "cube":
        refuse_stdout(output, "--grid cube writes six images into a folder")
    else:  # fail before the work
        image_format(output)
        check_output(output)
    return cog


def _with_crs(grid_kind, crs, from_raster):
    """The grid kind, ``("crs", CRS)`` with ``--crs`` (checked against the other options)."""
    if crs is None:
        return grid_kind
    if grid_kind == "cube":
        raise OptionError("--crs does not apply to --grid cube")
    if from_raster is not None:
        raise OptionError("--from-raster offsets lon/lat masks: no --crs")
    return ("crs", crs)


def _grid(grid_kind, size, bounds):
    """The grid of ``--grid``/``--size``/``--bounds`` and its number of levels."""
    if grid_kind == "cube":
        if bounds is not None:
            raise OptionError("--bounds does not apply to --grid cube")
        n = _face(size or "1024")
        return Cube(n), CubeFace(0, n).n_levels
    if isinstance(grid_kind, tuple):  # ("crs", CRS): a projected image
        projected = projected_grid(grid_kind[1], size, bounds)
        return projected, projected.n_levels
    w, h = _size(size or "4096x2048")
    grid = Equirect(w, h, _bounds(bounds))
    return grid, grid.n_levels


def _placement(grid, cog: bool, worldfile: bool, what: str) -> Placement:
    """Where the equirect image of ``grid`` lies, for the writers."""
    if what == "mask":
        desc = "gloffset mask: 255 inside the region, 0 outside"
    elif what == "styled":
        desc = "gloffset region: the fill colour inside, the background outside"
    elif what == "classes":
        desc = "gloffset classes: black contained, red frontier, white outside"
    else:
        desc = what
    if isinstance(grid, Projected):  # georeferenced in its CRS
        return Placement(projected_georef(grid, desc), cog=cog, worldfile=worldfile)
    return Placement(Georef(grid.transform(), description=desc), cog=cog, worldfile=worldfile)


def _grid_of_geotiff(path, bounds) -> tuple[np.ndarray, Equirect]:
    """A GeoTIFF mask and the equirect grid of its own transform."""
    if bounds is not None:
        raise OptionError("--bounds does not apply to a GeoTIFF mask: it has its own transform")
    band, ref = read_geotiff(path)
    a, _, west, _, e, north = ref.transform
    h, w = band.shape
    east, south = west + a * w, north + e * h
    east = east - 360.0 if east > 180.0 else east
    try:
        grid = Equirect(w, h, (west, max(south, -90.0), east, min(north, 90.0)))
    except InvalidGridError as exc:
        raise InputFormatError(f"{str(path)!r}: its transform is no lon/lat grid: {exc}") from None
    return band >= 128, grid


def _checked_style(fill, opacity, background) -> tuple:
    """``(fill, opacity, background)``, the colours read once to fail before the work."""
    for colour in (fill, background):
        if colour is not None:
            parse_color(colour)
    return fill, opacity, background


def _say_level_size(grid, level) -> None:
    """Say on stderr that ``--classes LEVEL`` below the output level is written at that
    level's size, not the grid's."""
    cube = isinstance(grid, Cube)
    ref = CubeFace(0, int(grid.size)) if cube else grid
    if level is None or not 0 <= level < ref.n_levels - 1:
        return  # the output level, or a bad level (refused by the render)
    (h, w), b = ref.level_shape(level), ref.block(level)
    whole = f"{grid.size}x{grid.size} faces" if cube else f"{grid.width}x{grid.height}"
    click.echo(
        f"--classes {level}: written at that level's size, {w}x{h} cells of {b}x{b} pixels of "
        f"the {whole} grid, without georeference",
        err=True,
    )


def _from_raster_grid(path, bounds) -> tuple[np.ndarray, Equirect]:
    """The curve mask of ``--from-raster`` and its equirect grid: a GeoTIFF's own, or a
    PNG on ``--bounds`` (without them the whole globe, for a 2:1 image only)."""
    if str(path).lower().endswith((".tif", ".tiff")):
        return _grid_of_geotiff(path, bounds)
    mask = read_mask(path)
    h, w = mask.shape
    if bounds is None and w != 2 * h:
        raise OptionError(
            f"--from-raster {str(path)!r} is {w}x{h} pixels, not 2:1: give the lon/lat it "
            "covers with --bounds W,S,E,N (only a 2:1 image is taken as the whole globe)"
        )
    return mask, Equirect(w, h, _bounds(bounds))


def _from_raster(path, distance, opts, where, mask_only, place, style=None):
    from ..raster.rasterized import raster_offset_with

    bounds, output = where
    mask, grid = _from_raster_grid(path, bounds)
    level = opts.level
    _say_level_size(grid, level)
    classes = raster_offset_with(mask, distance, grid, opts)
    at = None
    if level is None or level == grid.n_levels - 1:
        styled = mask_only and style is not None and style != (None, 1.0, None)
        what = ("styled" if styled else "mask") if mask_only else "classes"
        at = _placement(grid, place[0], place[1], what)
    _write_raster_classes(classes, output, mask_only, at, style)


def _write_raster_classes(classes, path, mask_only, place=None, style=None):
    if mask_only:
        fill, opacity, background = style or (None, 1.0, None)
        mask = np.where(classes == CONTAINED, 255, 0).astype(np.uint8)
        write_mask(mask, path, fill=fill, opacity=opacity, background=background, place=place)
    else:
        write_classes(classes, path, place=place)


def _out_folder(output) -> Path:
    folder = Path(output)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create folder {output!r}: {exc.strerror}") from None
    return folder


def read_cube_masks(folder) -> np.ndarray:
    """The six face masks ``px nx py ny pz nz`` (``.png``) of ``folder`` as one
    (6, N, N) bool array (any non-zero channel is curve), checked to be square and of
    one size."""
    folder = Path(folder)
    names = ", ".join(f"{n}.png" for n in FACE_NAMES)
    if not folder.is_dir():
        raise InputFormatError(
            f"--from-raster with --grid cube needs a folder holding {names}; "
            f"{str(folder)!r} is not a folder"
        )
    missing = [f"{n}.png" for n in FACE_NAMES if not (folder / f"{n}.png").is_file()]
    if missing:
        raise InputFormatError(
            f"cube face file(s) missing in {str(folder)!r}: {', '.join(missing)} "
            f"(a cube needs {names})"
        )
    faces = [read_mask(folder / f"{n}.png") for n in FACE_NAMES]
    for n, m in zip(FACE_NAMES, faces):
        if m.shape[0] != m.shape[1]:
            raise InputFormatError(
                f"cube face {n}.png is {m.shape[1]}x{m.shape[0]} pixels: faces must be square"
            )
    sizes = {m.shape[0] for m in faces}
    if len(sizes) > 1:
        each = ", ".join(f"{n}.png {m.shape[0]}" for n, m in zip(FACE_NAMES, faces))
        raise InputFormatError(f"cube faces must all have one size, got {each}")
    return np.stack(faces)


def _from_raster_cube(path, distance, opts, output, mask_only, style=None):
    from ..raster.rasterized import raster_offset_with

    mask = read_cube_masks(path)
    grid = Cube(mask.shape[1])
    _say_level_size(grid, opts.level)
    classes = raster_offset_with(mask, distance, grid, opts)
    folder = _out_folder(output)
    for k, name in enumerate(FACE_NAMES):
        _write_raster_classes(classes[k], folder / f"{name}.png", mask_only, style=style)


@main.command("info")
def info_cmd():
    """Print the OpenGL device gloffset renders with, and its limits."""
    from ..gl.context import context_info

    for key, val in context_info().items():
        click.echo(f"{key}: {val}")
