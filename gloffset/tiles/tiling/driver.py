"""Web-mercator tile pyramids of the offset region, driven by the tile quadtree.

The XYZ quadtree is used as a level hierarchy (level = zoom): every visited tile is
classified in float64 with the decision rules of :mod:`gloffset.raster.vector.levels`
(:func:`~gloffset.raster.vector.levels.decide`), with the tile centre and the bound

    r(z, y) = the largest angle from the centre to any point of the tile's lon/lat
              rectangle (the same for every tile of a row),

so a tile found *outside* has no point, and a tile found *contained* only points,
in the region, and so have all its descendants. Then

* outside: nothing is written and the descendants are never visited;
* contained: the tile and all its descendants down to the maximum zoom are written
  with one shared image (one blob in MBTiles, hard links in a directory), without
  rendering;
* frontier: the tile is rendered with :func:`gloffset.render` on its
  :class:`~gloffset.grids.Tile` grid (tiles with no pixel inside are not written)
  and its children are visited.

Candidate arcs are refined from parent to child as in the raster engine. Frontier tiles
are rendered from their bins (deeper levels of the same quadtree), many tiles to one
GPU pass, with the answer of :func:`gloffset.render` on the tile's
:class:`~gloffset.grids.Tile` grid: same pixel centres, same decision rules and
precision. Each zoom is classified before its tiles are written, so progress
(:class:`~.progress.TileProgress`) knows the tiles ahead. The derivation in full:
``docs/design.md``, *Module notes*.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ...ellipsoid import as_ellipsoid
from ...errors import InvalidGridError, TilesError
from ...grids.mercator import MAX_ZOOM, TilePyramid, check_tile_size
from ...grids.tms import ProjectedQuadLevels, tms_quad
from ...raster import driver
from ...raster.driver import Level
from ...raster.gpu import gpu_refine_pairs
from ...raster.vector.curves import CurveCells
from ...raster.vector.levels import subset
from ...shape import read
from ...units import RASTER_LIMIT, offset_angle, to_metres
from ..store.tilestore import INPUT_KEY, TILE_FILES, check_store, input_digest, open_store
from .ellipsoid import run_ellipsoid_pyramid
from .job import PyramidJob, PyramidOptions, pyramid_options
from .malloc import keep_freed_memory
from .metadata import (
    check_resume,
    describe,
    final_bounds,
    options_json,
    source_name,
    store_metadata,
)
from .progress import PyramidStats, Tracker
from .walk import BIN_LOG2, PYRAMID_ALONE_ZOOM, BinChain, MemoryStore, ZoomWriter

__all__ = [
    "pyramid",
    "pyramids",
    "write_pyramid",
    "check_pyramids",
    "PyramidOptions",
    "parse_zooms",
    "run_pyramid",
    "subpyramid",
    "Part",
    "PyramidJob",
    "TilesError",
    "MAX_ZOOM",
]


def parse_zooms(zooms) -> tuple[int, int]:
    """``(min, max)`` from ``"0-14"``, ``"5"``, an int or a pair, checked against 0..MAX_ZOOM
    (:data:`gloffset.grids.mercator.MAX_ZOOM`, 22).

    Examples
    --------
    >>> parse_zooms("0-14")
    (0, 14)
    >>> parse_zooms(5)
    (5, 5)
    """
    if isinstance(zooms, str):
        m = re.fullmatch(r"\s*(\d+)\s*(?:-\s*(\d+)\s*)?", zooms)
        if not m:
            raise TilesError(
                f"bad zoom range {zooms!r}: use MIN-MAX or one ZOOM, e.g. 0-14 "
                f"(zooms 0..{MAX_ZOOM})"
            )
        lo = int(m.group(1))
        hi = int(m.group(2)) if m.group(2) is not None else lo
    elif isinstance(zooms, (int, np.integer)):
        lo = hi = int(zooms)
    else:
        try:
            lo, hi = (int(v) for v in zooms)
        except (TypeError, ValueError):
            raise TilesError(f"zooms must be 'MIN-MAX', an int or a pair, got {zooms!r}") from None
    if not 0 <= lo <= hi <= MAX_ZOOM:
        raise TilesError(
            f"bad zoom range {lo}-{hi}: need 0 <= MIN <= MAX <= {MAX_ZOOM} "
            f"(gloffset renders tiles up to zoom {MAX_ZOOM})"
        )
    return lo, hi


def pyramid(shape, distance: float | str, zooms, out, **options) -> PyramidStats:
    """Write the tile pyramid (web mercator, or another ``tms``) of the offset region of
    ``shape``.

    Parameters
    ----------
    shape : Shape or anything :func:`gloffset.read` accepts
    distance : float or str
        A number in the units of ``radius`` (metres by default) or a distance with its
        unit (``"127km"``, ``"0.02rad"``: :func:`gloffset.parse_distance`); negative
        shrinks polygons. With ``ellipsoid``, a geodesic length (metres, or a string with
        a length unit).
    zooms : str, int or (int, int)
        Zoom range, e.g. ``"0-14"`` (at most 0..22).
    out : str, Path or a tile store
        A path ending in ``.mbtiles`` (MBTiles 1.3, TMS rows), ``.pmtiles`` (PMTiles v3;
        needs the ``pmtiles`` package) or a directory (``z/x/y.png``); or a writer from
        :func:`gloffset.tiles.store.tilestore.open_store`.
    **options
        Keywords, below (:class:`~gloffset.tiles.tiling.job.PyramidOptions`); another
        is a :class:`TypeError` that lists them.

    Other Parameters
    ----------------
    radius : float
        The sphere's radius (default :data:`gloffset.EARTH_RADIUS`, metres).
    size : int
        Tile side in pixels, a power of two from 16 to 4096.
    fill : str
        The region's colour (the style: :class:`gloffset.tiles.tiling.tilepaint.TileStyle`).
    opacity : float
        Its opacity, 0 to 1, on a transparent background.
    outline : str, optional
        The colour of an outline of the original curves (None: no outline).
    outline_width : int
        The outline's width in pixels.
    resume : bool
        Complete an existing output written with the same options, skipping the
        tiles it has; the result is the same as one uninterrupted run.
    overwrite : bool
        Replace an existing output.
    name : str, optional
        The ``name`` metadata (default: the file or directory name).
    source : str, optional
        The input's name in the ``description`` metadata (default: the file stem when
        ``shape`` is a path, else "the input"), next to the distance as given and its
        value in metres and radians.
    progress : callable, optional
        Called with a :class:`~.progress.TileProgress` before the first tile, after each tile or
        batch of tiles handled, and at the end (``done == total``, ``eta == 0``).
    max_block : int
        Frontier tiles per GPU run: at most ``(max_block / size)^2``.
    workers : int, optional
        Render on a Dask ``LocalCluster`` of this many worker processes (extra ``dask``):
        this process classifies the zooms down to a coarse one, writes their decided
        tiles and hands every other tile to the workers (the frontier tiles above that
        zoom one by one, the kept tiles of that zoom with their sub-pyramids:
        :mod:`gloffset.tiles.tiling.distributed`); each worker makes its own GL context; the
        tiles stream back to this process, which writes them. The output is
        byte-identical to a run in one process.
    scheduler : str, optional
        The address of a running Dask scheduler to use instead of a local cluster.
    ellipsoid : None, "WGS84", "GRS80", (a, f) or Ellipsoid
        ``None``: the sphere of ``radius``. Otherwise ``distance`` is a geodesic length
        in metres on the ellipsoid (a string takes length units only), and every tile
        equals ``render(shape, distance, Tile(z, x, y, size), ellipsoid=...)``
        (:mod:`gloffset.tiles.tiling.ellipsoid`; no outline, no workers).
    tms : str or morecantile.TileMatrixSet, optional
        The OGC TileMatrixSet of the tiles (its identifier, e.g. ``"WorldCRS84Quad"``, or
        a morecantile ``TileMatrixSet``; :func:`gloffset.grids.TmsTile`); default
        ``WebMercatorQuad``. Another TMS is written to a folder (``z/x/y.png``, its OGC
        JSON document beside the tiles in ``tileMatrixSet.json``; MBTiles and PMTiles hold
        web-mercator tiles only), its tile size the TMS's, no outline, no ellipsoid; each
        tile equals ``render(shape, distance, TmsTile(tms, z, x, y))``. TMSs in lon/lat
        (``WorldCRS84Quad``, ``WGS1984Quad``) and in polar stereographic CRSs
        (``UPSArcticWGS84Quad``, ``UPSAntarcticWGS84Quad``) are supported; the frontier
        tiles of a projected TMS render each on its own grid.

    Returns
    -------
    PyramidStats

    Notes
    -----
    The process keeps the memory it frees for reuse from then on
    (:func:`gloffset.tiles.tiling.malloc.keep_freed_memory`, glibc only): a pyramid makes and
    frees large arrays at every zoom, and giving them back to the system cost a fifth of
    its time.

    Contract: a tile is in the output iff some pixel centre of it is in the region
    (as decided by :func:`gloffset.render`, exact up to its stated epsilon), or,
    with an outline, the outline crosses it. Tiles written as fully inside
    without rendering have every point in the region. The tiles of a zoom are
    classified in float64 before any is rendered; only frontier tiles are rendered.

    Examples
    --------
    >>> import gloffset, tempfile, os
    >>> tri = {"type": "Polygon", "coordinates": [[[0, 0], [10, 0], [5, 8], [0, 0]]]}
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     st = gloffset.tiles.pyramid(tri, 100e3, "0-2", os.path.join(tmp, "t.mbtiles"),
    ...                                 size=64)
    >>> st.written, st.rendered, st.inside
    (4, 9, 0)
    """
    return write_pyramid(shape, distance, zooms, out, pyramid_options(options))


def write_pyramid(shape, distance, zooms, out, options: PyramidOptions) -> PyramidStats:
    """:func:`pyramid` with its keywords as one :class:`~.job.PyramidOptions`."""
    o = options
    t0 = time.perf_counter()
    keep_freed_memory()  # a pyramid makes and frees large arrays at every zoom
    source = o.source if o.source is not None else source_name(shape)
    shape = read(shape)
    job, ell, radius, params = _plan(shape, distance, zooms, out, o)
    zlo, zhi, quad = job.zlo, job.zhi, job.quad
    if isinstance(out, (str, Path)):
        _check_output(out, params, shape, o)  # before anything is written or unpacked
        label = o.name or Path(out).stem or "gloffset"
        desc = describe(distance, job.d, radius, source)
        if ell is not None:
            desc += f"; geodesic distance on {ell}"
        meta = {**store_metadata(label, desc, (zlo, zhi), params), INPUT_KEY: input_digest(shape)}
        if quad is not None:
            meta["tileMatrixSet"] = quad.id
            meta["bounds"] = ",".join(repr(v) for v in quad.lonlat_bounds())
        store = open_store(out, meta, resume=o.resume, overwrite=o.overwrite)
    else:
        store = out
    stats = PyramidStats()
    try:
        if o.resume:
            check_resume(store.metadata(), params, shape, getattr(store, "path", out))
        have = store.existing() if o.resume else set()
        if ell is not None:
            run_ellipsoid_pyramid(job, ell, store, have, stats)
        elif o.workers is None and o.scheduler is None:
            run_pyramid(job, store, have, o.progress, stats)
        else:
            from .distributed import run_distributed

            def split(first, count, last):
                part = Part(split=(first, count, last))
                return run_pyramid(job, store, have, o.progress, stats, part=part)

            run_distributed(
                job,
                store,
                have,
                o.progress,
                stats,
                run=split,
                task=subpyramid,
                workers=o.workers,
                scheduler=o.scheduler,
            )
        store.set_metadata(final_bounds(store, (zlo, zhi), quad))
        if quad is not None and isinstance(out, (str, Path)):  # an XYZ folder (pyramid_quad)
            store.put_document(TMS_DOCUMENT, quad.document().encode())
        store.finish()
    finally:
        store.close()
    stats.seconds = time.perf_counter() - t0
    return stats


def _plan(shape, distance, zooms, out, o: PyramidOptions):
    """The job of the pyramid of ``distance`` into ``out`` (every option checked), its
    ellipsoid (or None), the radius its angle is on, and its options as a resumed run must
    match them."""
    ell = as_ellipsoid(o.ellipsoid)
    radius = o.radius
    if ell is not None:
        to_metres(distance)  # a geodesic length: no angle units
        radius = ell.a  # the distance in metres, its angle on the sphere of radius a
    d = offset_angle(shape, distance, radius, limit=RASTER_LIMIT, what="a tile pyramid")
    zlo, zhi = parse_zooms(zooms)
    size = check_tile_size(o.size, TilesError)
    quad = pyramid_quad(o, out, zhi)
    params = options_json(d, (zlo, zhi), size, o.style, ell, quad)
    job = PyramidJob(
        shape=shape,
        d=d,
        zlo=zlo,
        zhi=zhi,
        size=size,
        style=o.style,
        max_block=o.max_block,
        quad=quad,
    )
    if ell is not None and (o.style.outline is not None or o.workers is not None or o.scheduler):
        raise TilesError("on an ellipsoid, pyramids take no outline, workers or scheduler")
    return job, ell, radius, params


def _check_output(out, params: str, shape, o: PyramidOptions) -> None:
    """Refuse, reading only, an output that exists without ``resume`` or ``overwrite``, or
    that ``resume`` cannot continue (other options, another input)."""
    have = check_store(out, resume=o.resume, overwrite=o.overwrite)
    if o.resume and have is not None:
        check_resume(have, params, shape, out)


def check_pyramids(shape, distances, zooms, outs, options: PyramidOptions) -> None:
    """Check the pyramids of several distances before any is written: every distance and
    option (:class:`~gloffset.errors.TilesError`,
    :class:`~gloffset.errors.InvalidDistanceError`) and every output, free, replaced
    (``overwrite``) or continued by ``resume`` with the same options and input
    (:class:`~gloffset.errors.OutputExistsError`, :class:`~gloffset.errors.OutputError`,
    :class:`~gloffset.errors.TilesError`). Reads only: nothing is written or unpacked."""
    shape = read(shape)
    for distance, out in zip(distances, outs):
        _, _, _, params = _plan(shape, distance, zooms, out, options)
        if isinstance(out, (str, Path)):
            _check_output(out, params, shape, options)


def pyramids(shape, distances, zooms, outs, **options) -> list[PyramidStats]:
    """The pyramids of several distances of one shape: ``outs[k]`` is the pyramid of
    ``distances[k]``, the same output as ``pyramid(shape, distances[k], zooms, outs[k],
    **options)`` (tiles and metadata), from one read of the input.

    The runs share what does not depend on the distance: the input read and checked
    once (with its ``source`` name), the caches a :class:`~gloffset.Shape` keeps (its
    arcs, the inside test's index, the multiresolution decomposition) and the GL context.
    Each distance walks its own zooms: a tile's class and candidate arcs depend on the
    distance. Every distance and output is checked (:class:`~gloffset.errors.TilesError`,
    :class:`~gloffset.errors.InvalidDistanceError`) before any is written.
    """
    distances, outs = list(distances), list(outs)
    if not distances or len(distances) != len(outs):
        raise TilesError(
            f"pyramids needs one output per distance, got {len(distances)} distances and "
            f"{len(outs)} outputs"
        )
    if len({str(o) for o in outs}) != len(outs):
        raise TilesError(f"pyramids needs a different output per distance, got {outs}")
    opts = pyramid_options(options, "pyramids")
    opts = opts if opts.source is not None else replace(opts, source=source_name(shape))
    shape = read(shape)
    check_pyramids(shape, distances, zooms, outs, opts)
    return [write_pyramid(shape, dist, zooms, out, opts) for dist, out in zip(distances, outs)]


#: The file beside an XYZ folder's tiles that holds the TileMatrixSet (its OGC JSON) when
#: it is not web mercator.
TMS_DOCUMENT = "tileMatrixSet.json"


def pyramid_quad(o: PyramidOptions, out, zhi: int):
    """The :class:`~gloffset.grids.tms.TmsQuad` of ``o.tms`` (None for web mercator),
    checked against the other options and the output before any work
    (:class:`~gloffset.errors.TilesError`)."""
    if o.tms is None:
        return None
    quad = tms_quad(o.tms, TilesError)
    if quad.kind == "mercator":
        if o.size != quad.size:
            raise TilesError(f"the tiles of {quad.id} are {quad.size} pixels, not {o.size}")
        return None
    if isinstance(out, (str, Path)) and Path(out).suffix.lower() in TILE_FILES:
        raise TilesError(
            f"{Path(out).suffix} holds web-mercator tiles only: write the tiles of {quad.id} "
            "to a folder (z/x/y.png, with the TileMatrixSet beside them)"
        )
    if quad.kind == "projected":
        try:
            ProjectedQuadLevels(quad, 0)  # a bound of the projection
        except InvalidGridError as e:
            raise TilesError(str(e)) from None
    if o.size != quad.size:
        raise TilesError(f"the tiles of {quad.id} are {quad.size} pixels, not {o.size}")
    if zhi > quad.maxzoom:
        raise TilesError(f"{quad.id} has zooms 0 to {quad.maxzoom}, not {zhi}")
    if o.ellipsoid is not None or o.style.outline is not None:
        raise TilesError(f"pyramids of {quad.id} take no outline and no ellipsoid")
    return quad


def run_pyramid(job: PyramidJob, store, have, progress, stats, *, part=None):
    """Write the tiles of ``job`` into ``store`` (skipping ``have``); see :class:`Part`
    for a run that classifies down to a split and returns the tasks of the tiles left, or
    writes one tile's subtree only."""
    shape, d, zlo, zhi, size, style = job.shape, job.d, job.zlo, job.zhi, job.size, job.style
    max_block = job.max_block
    plog = size.bit_length() - 1
    levels: TilePyramid | ProjectedQuadLevels
    if job.quad is not None and job.quad.kind == "projected":
        # the tiles' own levels; each frontier tile renders on its own grid
        levels = ProjectedQuadLevels(job.quad, zhi)
        nb = 0
    else:
        levels = TilePyramid(zhi + plog, quad=job.quad)  # down to the deepest tiles' pixels
        nb = max(0, plog - BIN_LOG2)
    # the levels no tile is rendered from (bins of zooms drawn alone or not written)
    # classify with the multiresolution curve: their lists follow the cells' size
    until = None if style.outline is not None else max(PYRAMID_ALONE_ZOOM, zlo - 1) + nb
    split = part is not None and part.split is not None
    # a run that renders refines its levels' pairs on its GL context
    cells = CurveCells(
        shape, d, levels, nodes_until=until, refine_pairs=None if split else gpu_refine_pairs
    )
    chain = BinChain(cells, nb)
    cells.remember(chain.nb)  # the walk reaches the chain's levels later: computed once
    track = Tracker(zlo, zhi, progress)
    writer = ZoomWriter(cells, style, store, have, size, stats, track)
    start = None if part is None else part.start
    if part is not None and part.root is not None and start is None:
        raise ValueError("a run of one tile's subtree starts from the tile's level")
    stop = zhi if part is None or part.last is None else min(zhi, part.last)
    tasks = []  # a split run's: (tile, forced class, its one-cell level, last zoom)
    for lev in driver.walk(cells, stop, start=start):
        if len(lev.cells) == 0:
            break
        root = part is not None and part.root is not None and lev.level == part.root[0]
        if not split:
            writer.run(lev, chain, (zlo, zhi), max_block, root=root, final=lev.level >= stop)
            continue
        # a split run writes the decided tiles; the others become tasks: the frontier
        # tiles above the split zoom one by one, the kept tiles of the split zoom with
        # their subtrees
        chosen = writer.choose(lev)
        at = part.split_at(lev)
        front = writer.run(lev, chain, (zlo, zhi), max_block, chosen=chosen, kept_too=at)
        assert lev.keep is not None and lev.forced is not None  # chosen
        z = lev.level
        mine = lev.keep if at else front
        for i in mine:
            y, x = (int(v) for v in lev.cells[i])
            forced = int(lev.forced[np.searchsorted(lev.keep, i)])
            tasks.append(((z, x, y), forced, _one(lev, i), zhi if at else z))
        if at:
            break
    if not split:
        track.finish()
    return tasks, track


def _one(lev: Level, i: int) -> Level:
    """Cell ``i`` of ``lev`` as a level of its own (what a task below it starts from)."""
    sel = np.array([i])
    m = None if lev.measure is None else lev.measure[sel]
    return Level(lev.level, lev.cells[sel], lev.cls[sel], subset(lev.state, sel), measure=m)


@dataclass
class Part:
    """A part of a pyramid run: ``split`` (the run classifies the zooms down to the
    first zoom ``z`` from ``split[0]`` on where at least ``split[1]`` tiles are kept,
    or to ``split[2]``, and writes only their decided tiles: it returns the others as
    tasks, the frontier tiles of the zooms above ``z`` one by one and the kept tiles of
    ``z`` with their subtrees, each with its one-cell
    :class:`~gloffset.raster.driver.Level`) or ``root`` (``(z, x, y)``: only that tile
    and its descendants down to ``last`` are written; the walk starts from ``start``,
    the root's one-cell level as the split made it).
    Every tile's pixels are those of the whole run: a tile's candidate arcs and classes
    depend on its ancestors only."""

    split: tuple[int, int, int] | None = None
    root: tuple[int, int, int] | None = None
    start: Level | None = None  # the root's level as the split made it
    last: int | None = None  # the deepest zoom written (default: the pyramid's)

    def split_at(self, lev: Level) -> bool:
        if self.split is None:
            return False
        first, count, last = self.split
        kept = 0 if lev.keep is None else len(lev.keep)
        return lev.level >= last or (lev.level >= first and kept >= count)


def subpyramid(
    job: PyramidJob, root, have, start: Level | None = None, last: int | None = None
) -> tuple[list, PyramidStats]:
    """The tile ``root`` (``(z, x, y)``) of the pyramid ``job`` and its descendants down
    to zoom ``last`` (default: the pyramid's deepest), as ``[(tiles, image)]``, and the
    task's counts; ``have``: tiles to skip (a resumed output's)."""
    keep_freed_memory()
    store = MemoryStore()
    stats = PyramidStats()
    part = Part(root=root, start=start, last=last)
    run_pyramid(job, store, have, None, stats, part=part)
    return [(tiles, data) for data, tiles in store.groups.items()], stats
