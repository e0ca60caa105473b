"""Web-mercator tile pyramids of the offset region, driven by the tile quadtree.

The XYZ quadtree is used as a level hierarchy (level = zoom): every visited tile is
classified in float64 with the decision rules of :mod:`gloffset.raster.levels`
(:func:`~gloffset.raster.levels.decide`), with the tile centre and the bound

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

Candidate arcs are refined from parent to child as in the raster engine, with the
list bound ``L(z, y) = r(z, y) + sum_{k=1..Z-z} r_eq(z + k)`` (``Z`` the maximum zoom,
``r_eq(z)`` the bound of a tile touching the equator, the largest of its zoom): a
chain parent -> child -> ... moves at most ``r`` of each tile it passes, so
``L(parent) >= angle(parent, child) + L(child)`` as the refinement requires.

Frontier tiles are rendered without starting again from the top: pixel ``(i, j)`` of
tile ``z/x/y`` (``size = 2^P``) is the centre of tile ``z+P / x 2^P + i / y 2^P + j``,
so a tile's pixels, and its bins of 16 pixels, are deeper levels of the same
quadtree. The hierarchy runs to zoom ``max + P``: the frontier tiles of zoom ``z``
are refined in float64 down to their bins (zoom ``z + P - 4``; these levels are
kept from zoom to zoom, so each zoom adds one, :class:`_BinChain`), and the GPU levels
(:class:`gloffset.gl.vector_pass.VectorPasses`) classify the frontier bins of up to
``(max_block / size)^2`` tiles at once, packed into one small canvas
(:class:`~gloffset.raster.layout.BinLayout`); every other pixel of a tile is its bin's
class. So the cost per tile is that of its frontier bins, not a render call. The
answer is that of :func:`gloffset.render` on the tile's :class:`~gloffset.grids.Tile`
grid: same pixel centres, same decision rules and precision.

With an outline, decided tiles that a boundary arc may cross (distance to the
boundary at most ``r``) are drawn (fill or nothing, plus the outline) and
their children visited with the same class; the rest are as above.

Progress (:class:`TileProgress`): each zoom is classified before any of its tiles is
written, and the bin levels hold the frontier and inside tiles of the next zooms, so
the run knows its tiles ahead and estimates the rest from the growth of the frontier;
the time left follows a per-zoom cost plus a per-tile cost, both measured as it goes.
"""

from __future__ import annotations

import functools
import json
import math
import re
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..._version import __version__
from ...edges import CurveArcs, inside_any
from ...ellipsoid import as_ellipsoid
from ...errors import TilesError
from ...grids.conformal import ConformalRows
from ...grids.mercator import MAX_ZOOM, Tile, TilePyramid, check_tile_size, lat_at
from ...io.tilestore import open_store
from ...malloc import keep_freed_memory
from ...shape import read
from ...units import EARTH_RADIUS, RASTER_LIMIT, offset_angle, parse_distance
from .. import driver
from ..curves import CurveCells
from ..driver import CONTAINED, FRONTIER, NOT_FORCED, OUTSIDE, Level
from ..layout import BinLayout
from ..levels import at_cells, cell_distances, decide, subset
from ..render import render, render_grid
from .ellipsoid import run_ellipsoid_pyramid
from .tilepaint import OutlineArcs, TileStyle

__all__ = [
    "pyramid",
    "parse_zooms",
    "PyramidStats",
    "TileProgress",
    "TilesError",
    "MAX_ZOOM",
    "render_tiles",
    "measure_tiles",
    "TileCentre",
    "ALONE_ZOOM",
]

#: Frontier tiles rendered per GPU run: (MAX_BLOCK / tile size)^2.
MAX_BLOCK = 4096
#: Output pixels per side of a bin (below it the GPU takes over).
_BIN_LOG2 = 4


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


# ---------------------------------------------------------------------- geometry
# ---------------------------------------------------------------------- results
@dataclass
class PyramidStats:
    """What a pyramid run did (counts of tiles at zooms min..max).

    ``rendered``: frontier tiles rendered on the GPU; ``empty``: of those, tiles
    with no pixel inside (not written); ``inside``: tiles written as fully inside
    without rendering (descendants of contained tiles included); ``painted``:
    decided tiles drawn with an outline without rendering; ``outside``: tiles found
    outside (their descendants never visited); ``present``: tiles skipped because a
    resumed output had them; ``render_calls``: batched render calls.
    """

    rendered: int = 0
    empty: int = 0
    inside: int = 0
    painted: int = 0
    outside: int = 0
    present: int = 0
    render_calls: int = 0
    seconds: float = 0.0
    zooms: dict = field(default_factory=dict)

    @property
    def written(self) -> int:
        """Tiles written by this run (rendered non-empty, inside, painted)."""
        return self.rendered - self.empty + self.inside + self.painted

    def as_dict(self) -> dict:
        return {
            "rendered": self.rendered,
            "empty": self.empty,
            "inside": self.inside,
            "painted": self.painted,
            "outside": self.outside,
            "present": self.present,
            "written": self.written,
            "render_calls": self.render_calls,
            "seconds": self.seconds,
            "zooms": self.zooms,
        }


# ---------------------------------------------------------------------- progress
@dataclass(frozen=True)
class TileProgress:
    """Where a pyramid run stands; :func:`pyramid` hands one to ``progress`` before the
    first tile, after each tile or batch of tiles handled, and at the end.

    Tiles count at zooms min..max: frontier tiles (rendered, written or empty),
    outlined tiles and every tile of a fully-inside subtree, already present ones
    included; tiles found outside are not counted.

    Attributes
    ----------
    zoom : int
        The zoom being classified or written.
    done : int
        Tiles handled so far.
    total : int
        Estimate of the tiles the run handles in all: the tiles of the zooms classified
        so far are known exactly, the next zooms' frontier and inside tiles too where the
        bin levels below the frontier tiles already hold them (from the zoom before the
        first one written; 4 zooms ahead for 256 px tiles), and deeper zooms follow the
        growth of the frontier from zoom to zoom. On Dask workers, once a task has
        ended, the tasks left count the mean tiles of those ended. Never below ``done``;
        equal to it at the end, and only there.
    seconds : float
        Since the run started.
    eta : float or None
        Estimated seconds left: the tiles left of each kind (rendered or outlined, and
        inside) at the seconds per tile measured so far for that kind, plus a fixed cost
        per zoom (measured too); None during the first zoom (for a one-zoom run: until a
        tile has been rendered); 0 at the end. On Dask workers: the heavy tiles left at
        the pace the tasks have kept so far (None until one has ended).
    """

    zoom: int
    done: int
    total: int
    seconds: float
    eta: float | None

    @property
    def fraction(self) -> float:
        """Share of the run's time done, ``seconds / (seconds + eta)`` (0 while the ETA
        is unknown); exactly 1 at the end and only there."""
        if self.done >= self.total:
            return 1.0
        if self.eta is None or self.seconds + self.eta <= 0.0:
            return 0.0
        return min(self.seconds / (self.seconds + self.eta), 1.0 - 1e-9)


#: Seconds per inside tile over seconds per rendered tile, until both are measured
#: (MBTiles: about 1/500, a directory of hard links: about 1/30).
_LIGHT_PRIOR = 0.01
#: A zoom's fixed cost is taken as at most that of this many rendered tiles (one GPU run
#: of 256 px tiles), until a zoom has more tiles than that.
_ZOOM_TILES = 256


class _Tracker:
    """Counts the tiles of a run by kind (heavy: frontier and outlined tiles; light: the
    tiles of fully-inside subtrees), estimates the tiles still to come (see
    :class:`TileProgress`) and the time they take, and calls ``progress``.

    Time model: a zoom's heavy work costs ``a + b n`` seconds for ``n`` heavy tiles
    (``a``: the float64 levels, GPU runs and commit that every zoom has; ``b``: a tile's
    share of rendering, encoding and writing), ``a`` the cheapest zoom so far and ``b``
    from the latest zoom (at least ``a / 256``); inside tiles cost the mean measured so
    far.
    """

    def __init__(self, zlo: int, zhi: int, progress):
        self.zlo, self.zhi, self.progress = zlo, zhi, progress
        self.t0 = time.perf_counter()
        self.zoom = 0
        self.done = [0, 0]  # heavy, light
        self.known = [0, 0]  # tiles of the zooms classified so far (done included)
        self.future = [0.0, 0.0]  # estimated tiles of the zooms below
        self.future_zooms = 0  # zooms below with heavy tiles (estimated)
        self.skipped = [0, 0]  # already present (no time spent)
        self.light_s = 0.0  # seconds writing inside tiles
        self.setup_s = 0.0  # seconds spent once (the GL context)
        self.frontier: dict[int, int] = {}  # zoom -> frontier tiles (classified or ahead)
        self.contained: dict[int, int] = {}  # zoom -> newly contained tiles
        self.zooms: list[tuple[int, float]] = []  # per finished zoom: heavy tiles, seconds
        self.mark = None  # at the current zoom's start: (heavy worked, heavy seconds)
        self.last: TileProgress | None = None
        self.tasks: dict | None = None  # a split run's tasks (:meth:`start_tasks`)

    def _sub(self, z: int) -> int:
        """Tiles of a subtree rooted at zoom ``z`` within zooms min..max."""
        return sum(4 ** (zz - z) for zz in range(max(z, self.zlo), self.zhi + 1))

    def _heavy(self, now: float) -> tuple[int, float]:
        """Heavy tiles worked (not skipped) and heavy seconds, so far."""
        return self.done[0] - self.skipped[0], now - self.t0 - self.light_s - self.setup_s

    def plan(self, z, *, front, contained, carried_in, carried_out, ahead):
        """Zoom ``z`` is classified: its tiles are known, the deeper zooms re-estimated
        (``ahead``: (frontier, contained) of zooms z+1.. from the bin levels)."""
        now = time.perf_counter()
        if self.mark is not None:
            n, sec = self._heavy(now)
            self.zooms.append((n - self.mark[0], sec - self.mark[1]))
        self.mark = self._heavy(now) if z >= self.zlo else None
        self.zoom = z
        inz = z >= self.zlo
        self.known[0] += (front + carried_in + carried_out) * inz
        self.known[1] += contained * self._sub(z)
        self.frontier[z], self.contained[z] = front, contained
        for k, (fr, co) in enumerate(ahead, start=z + 1):
            if k > self.zhi:
                break
            self.frontier[k], self.contained[k] = fr, co
        deep = max(self.frontier)
        # frontier growth per zoom and contained tiles per parent frontier tile, from
        # the two deepest zooms known
        prev = self.frontier.get(deep - 1, 0)
        grow = min(max(self.frontier[deep] / prev, 1.0), 4.0) if prev else 2.0
        per = min(self.contained[deep] / prev, 4.0) if prev else 0.0
        heavy = light = 0.0
        zooms = 0
        f = float(self.frontier[deep])
        for zz in range(z + 1, self.zhi + 1):
            if zz <= deep:
                fz, cz = self.frontier[zz], self.contained[zz]
            else:
                fz, cz = f * grow, per * f
                f = fz
            light += cz * self._sub(zz)
            if zz >= self.zlo:
                # outlined tiles: their children along the outline (about twice as many
                # per zoom) are outlined again, the others of the inside ones are inside
                line = 2.0 ** (zz - z)
                h = fz + (carried_in + carried_out) * line
                light += carried_in * (4.0 ** (zz - z) - line)
                heavy += h
                zooms += h >= 0.5
        self.future = [heavy, light]
        self.future_zooms = zooms
        self._emit()

    @contextmanager
    def light(self):
        """Times the writing of inside tiles."""
        t = time.perf_counter()
        try:
            yield
        finally:
            self.light_s += time.perf_counter() - t

    def setup(self, fn):
        """Call ``fn`` and keep its time out of the tiles' rates."""
        t = time.perf_counter()
        fn()
        self.setup_s += time.perf_counter() - t

    def tick(self, heavy: int = 0, light: int = 0, skipped: int = 0):
        if heavy:
            self.done[0] += heavy
            self.skipped[0] += skipped
        if light:
            self.done[1] += light
            self.skipped[1] += skipped
        if heavy or light:
            self._emit()

    def finish(self):
        self.known = list(self.done)
        self.future = [0.0, 0.0]
        self.future_zooms = 0
        self._emit()

    def _eta(self, now: float, left: list[float]) -> float | None:
        """Seconds left for ``left`` (heavy, light) tiles, or None before any measure."""
        n, sec = self._heavy(now)
        if self.zooms:
            a = min(t for _, t in self.zooms)
            last_n, last_t = self.zooms[-1]
            b = (last_t - a) / last_n if last_n else 0.0
            if self.mark is not None and n - self.mark[0] > last_n:
                b = (sec - self.mark[1] - a) / (n - self.mark[0])  # this zoom is larger
            b = max(b, a / _ZOOM_TILES)
        elif n > 0 and self.zlo == self.zhi:
            a, b = 0.0, sec / n  # one zoom: its rate so far
        else:
            return None  # within the first zoom
        worked_light = self.done[1] - self.skipped[1]
        light = self.light_s / worked_light if worked_light else b * _LIGHT_PRIOR
        return a * self.future_zooms + b * left[0] + light * left[1]

    def start_tasks(self, n: int):
        """The split is made: ``n`` tasks (run elsewhere) bring the tiles left."""
        self.tasks = {"n": n, "done": 0, "t0": time.perf_counter(), "heavy": 0, "light": 0}
        self._emit()

    def task_done(self, heavy: int, light: int, skipped: int):
        """A task ended with ``heavy`` rendered or outlined tiles, ``light`` inside ones
        and ``skipped`` already present (counted as done, as in one process)."""
        t = self.tasks
        t["done"] += 1
        t["heavy"] += heavy
        t["light"] += light + skipped
        self.done[0] += heavy
        self.done[1] += light + skipped
        self.skipped[1] += skipped
        self._emit()

    def _task_left(self, now: float):
        """Tiles left (heavy, light) and the ETA while tasks run: the tasks left at the
        mean tiles of those ended, and the time per heavy tile the tasks took so far
        (the split's estimates, and no ETA, until a task has ended); at least one tile
        per task left, so that the total is reached at the end only."""
        t = self.tasks
        n_left = t["n"] - t["done"]
        if t["done"] == 0:
            left = [max(0.0, self.known[i] + self.future[i] - self.done[i]) for i in (0, 1)]
            left[0] = max(left[0], float(n_left))
            return left, None
        left = [n_left * t["heavy"] / t["done"], n_left * t["light"] / t["done"]]
        left[0] = max(left[0], float(n_left))
        if n_left == 0:
            return [0.0, 0.0], 0.0
        work = max(t["heavy"], t["done"])
        return left, (now - t["t0"]) * max(left[0], n_left) / work

    def _emit(self):
        if self.progress is None:
            return
        done = self.done[0] + self.done[1]
        now = time.perf_counter()
        if self.tasks is not None:
            left, eta = self._task_left(now)
        else:
            left = [max(0.0, self.known[i] + self.future[i] - self.done[i]) for i in (0, 1)]
        total = done + math.ceil(left[0] + left[1])
        if total == done and self.last is not None and self.last.done == self.last.total:
            return  # the end, already reported
        if self.tasks is None or total == done:
            eta = 0.0 if total == done else self._eta(now, left)
        self.last = TileProgress(self.zoom, done, total, now - self.t0, eta)
        self.progress(self.last)


# ---------------------------------------------------------------------- the pyramid
def _params(d, zooms, size, style, ell=None) -> str:
    extra = {} if ell is None else {"ellipsoid": [ell.a, ell.f]}
    return json.dumps(
        {
            **extra,
            "distance_rad": repr(float(d)),
            "zooms": list(zooms),
            "tile_size": size,
            "fill": style.fill,
            "opacity": style.opacity,
            "outline": style.outline,
            "outline_width": style.outline_width,
        },
        sort_keys=True,
    )


def _metadata(name, description, zooms, params) -> dict:
    return {
        "name": name,
        "format": "png",
        "type": "overlay",
        "version": "1",
        "description": description,
        "minzoom": zooms[0],
        "maxzoom": zooms[1],
        "bounds": "-180.0,-85.051129,180.0,85.051129",
        "center": f"0.0,0.0,{zooms[0]}",
        "gloffset": params,
    }


def _source_name(shape) -> str | None:
    """The file stem of an input given as a path (None for anything else)."""
    if isinstance(shape, Path):
        return shape.stem
    if isinstance(shape, str) and shape != "-" and not shape.lstrip().startswith(("{", "[")):
        return Path(shape).stem
    return None


def _describe(distance, d: float, radius: float, source: str | None) -> str:
    """The ``description`` metadata of a pyramid: the distance as given (``"127km"``, or a
    number in metres), its value in metres and radians, and the input's name.

    Examples
    --------
    >>> _describe("127km", 127e3 / EARTH_RADIUS, EARTH_RADIUS, "mexico_10m").split(";")[0]
    'Region within 127km of mexico_10m, polygons included (127km = 127000 m = 0.019934 rad)'
    """
    value = f"{d * radius:.10g} m = {d:.6g} rad"
    if isinstance(distance, str):
        given = distance.strip()
        value = f"{given} = {value}"
    else:
        given = f"{float(distance):.10g} m"
    if radius != EARTH_RADIUS:
        value += f" on a sphere of radius {radius:.10g} m"
    src = source or "the input"
    if d < 0:
        size = given[1:].lstrip() if given.startswith("-") else given
        what = f"Points of {src} inside its polygons and farther than {size} from their boundary"
    else:
        what = f"Region within {given} of {src}, polygons included"
    return f"{what} ({value}); gloffset {__version__}"


def _final_bounds(store, zooms) -> dict:
    for z in range(zooms[1], zooms[0] - 1, -1):
        ext = store.extent(z)
        if ext is not None:
            x0, y0, x1, y1 = ext
            w, e = x0 * 360.0 / (1 << z) - 180.0, (x1 + 1) * 360.0 / (1 << z) - 180.0
            n, s = (math.degrees(float(lat_at(v, 1 << z))) for v in (y0, y1 + 1))
            b = (round(w, 6), round(s, 6), round(e, 6), round(n, 6))
            cz = min(zooms[1], max(zooms[0], z - 2))
            return {
                "bounds": ",".join(repr(v) for v in b),
                "center": f"{round((w + e) / 2, 6)},{round((s + n) / 2, 6)},{cz}",
            }
    return {}


def pyramid(
    shape,
    distance: float,
    zooms,
    out,
    *,
    radius: float = EARTH_RADIUS,
    size: int = 256,
    fill: str = "#3070c0",
    opacity: float = 1.0,
    outline: str | None = None,
    outline_width: int = 1,
    resume: bool = False,
    overwrite: bool = False,
    name: str | None = None,
    source: str | None = None,
    progress=None,
    max_block: int = MAX_BLOCK,
    workers: int | None = None,
    scheduler: str | None = None,
    ellipsoid=None,
) -> PyramidStats:
    """Write the web-mercator tile pyramid of the offset region of ``shape``.

    Parameters
    ----------
    shape : Shape or anything :func:`gloffset.read` accepts
    distance : float or str
        A number in the units of ``radius`` (metres by default) or a distance with its
        unit (``"127km"``, ``"0.02rad"``: :func:`gloffset.parse_distance`); negative
        shrinks polygons.
    zooms : str, int or (int, int)
        Zoom range, e.g. ``"0-14"`` (at most 0..22).
    out : str, Path or a tile store
        A path ending in ``.mbtiles`` (MBTiles 1.3, TMS rows), ``.pmtiles`` (PMTiles v3;
        needs the ``pmtiles`` package) or a directory (``z/x/y.png``); or a writer from
        :func:`gloffset.io.tilestore.open_store`.
    size : int
        Tile side in pixels, a power of two from 16 to 4096.
    fill, opacity, outline, outline_width
        The style (:class:`gloffset.raster.pyramid.tilepaint.TileStyle`): region colour and its
        opacity on a transparent background, and the colour and width of an
        outline of the original curves (None: no outline).
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
        Called with a :class:`TileProgress` before the first tile, after each tile or
        batch of tiles handled, and at the end (``done == total``, ``eta == 0``).
    max_block : int
        Frontier tiles per GPU run: at most ``(max_block / size)^2``.
    workers : int, optional
        Render on a Dask ``LocalCluster`` of this many worker processes (extra ``dask``):
        this process classifies the zooms down to a coarse one, writes their decided
        tiles and hands every other tile to the workers (the frontier tiles above that
        zoom one by one, the kept tiles of that zoom with their sub-pyramids:
        :mod:`gloffset.raster.pyramid.distributed`); each worker makes its own GL context; the
        tiles stream back to this process, which writes them. The output is
        byte-identical to a run in one process.
    scheduler : str, optional
        The address of a running Dask scheduler to use instead of a local cluster.
    ellipsoid : None, "WGS84", "GRS80", (a, f) or Ellipsoid
        ``None``: the sphere of ``radius``. Otherwise ``distance`` is a geodesic length
        in metres on the ellipsoid (a string takes length units only), and every tile
        equals ``render(shape, distance, Tile(z, x, y, size), ellipsoid=...)``
        (:mod:`gloffset.raster.pyramid.ellipsoid`; no outline, no workers).

    Returns
    -------
    PyramidStats

    Notes
    -----
    The process keeps the memory it frees for reuse from then on
    (:func:`gloffset.malloc.keep_freed_memory`, glibc only): a pyramid makes and frees
    large arrays at every zoom, and giving them back to the system cost a fifth of
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
    (12, 9, 6)
    """
    t0 = time.perf_counter()
    keep_freed_memory()  # a pyramid makes and frees large arrays at every zoom
    source = source if source is not None else _source_name(shape)
    shape = read(shape)
    ell = as_ellipsoid(ellipsoid)
    if ell is not None:
        radius = ell.a  # the distance in metres, its angle on the sphere of radius a
    if isinstance(distance, str):  # "127km": its angle (the limits apply to it)
        if ell is not None and distance.strip().lower().endswith(("rad", "deg")):
            raise TilesError(f"distance {distance!r}: on an ellipsoid give a length (m, km)")
        value, unit = parse_distance(distance, radius), 1.0
    else:
        value, unit = distance, radius
    d = offset_angle(shape, value, unit, limit=RASTER_LIMIT, what="a tile pyramid")
    zlo, zhi = parse_zooms(zooms)
    size = check_tile_size(size, TilesError)
    style = TileStyle(fill, opacity, outline, outline_width)
    params = _params(d, (zlo, zhi), size, style, ell)
    if ell is not None and (outline is not None or workers is not None or scheduler):
        raise TilesError("on an ellipsoid, pyramids take no outline, workers or scheduler")
    if isinstance(out, (str, Path)):
        label = name or Path(out).stem or "gloffset"
        desc = _describe(distance, d, radius, source)
        if ell is not None:
            desc += f"; geodesic distance on {ell}"
        store = open_store(
            out, _metadata(label, desc, (zlo, zhi), params), resume=resume, overwrite=overwrite
        )
    else:
        store = out
    stats = PyramidStats()
    try:
        if resume:
            have = store.metadata().get("gloffset")
            if have != params:
                raise TilesError(
                    f"cannot resume {str(getattr(store, 'path', out))!r}: it was written with "
                    f"other options ({have}); use --force to start again"
                )
        have = store.existing() if resume else set()
        if ell is not None:
            full = style.encode(np.ones((size, size), dtype=bool))
            args = (store, have, stats, full, tile_masks)
            run_ellipsoid_pyramid(shape, d * ell.a, ell, (zlo, zhi), size, style, *args)
        elif workers is None and scheduler is None:
            run_pyramid(shape, d, zlo, zhi, size, style, store, have, progress, max_block, stats)
        else:
            from .distributed import run_distributed

            job = (shape, d, zlo, zhi, size, style, max_block)

            def split(first, count, last):
                part = Part(split=(first, count, last))
                args = (store, have, progress, max_block, stats)
                return run_pyramid(shape, d, zlo, zhi, size, style, *args, part=part)

            run_distributed(
                job,
                store,
                have,
                progress,
                stats,
                run=split,
                task=subpyramid,
                workers=workers,
                scheduler=scheduler,
            )
        store.set_metadata(_final_bounds(store, (zlo, zhi)))
        store.finish()
    finally:
        store.close()
    stats.seconds = time.perf_counter() - t0
    return stats


def _subtree(x, y, z, zfrom, zto, chunk=65536):
    """XYZ coordinates of tile z/x/y and its descendants at zooms zfrom..zto, in chunks."""
    for zz in range(max(z, zfrom), zto + 1):
        k = zz - z
        n = 1 << k
        xs = np.arange(x << k, (x << k) + n)
        rows_per = max(1, chunk // n)
        for r0 in range(0, n, rows_per):
            ys = np.arange((y << k) + r0, (y << k) + min(n, r0 + rows_per))
            yy, xx = np.meshgrid(ys, xs, indexing="ij")
            yield zz, xx.ravel(), yy.ravel()


def run_pyramid(
    shape, d, zlo, zhi, size, style, store, have, progress, max_block, stats, *, part=None
):
    """Write the pyramid's tiles into ``store`` (skipping ``have``); see :class:`Part`
    for a run that classifies down to a split and returns the tasks of the tiles left, or
    writes one tile's subtree only."""
    plog = size.bit_length() - 1
    levels = TilePyramid(zhi + plog)  # down to the pixels of the deepest tiles
    nb = max(0, plog - _BIN_LOG2)
    # the levels no tile is rendered from (bins of zooms drawn alone or not written)
    # classify with the multiresolution curve: their lists follow the cells' size
    until = None if style.outline is not None else max(PYRAMID_ALONE_ZOOM, zlo - 1) + nb
    cells = CurveCells(shape, d, levels, nodes_until=until)
    chain = _BinChain(cells, nb)
    cells.remember(chain.nb)  # the walk reaches the chain's levels later: computed once
    track = _Tracker(zlo, zhi, progress)
    job = _Zoom(cells, style, store, have, size, stats, track)
    start = None if part is None else part.start
    if part is not None and part.root is not None and start is None:
        raise ValueError("a run of one tile's subtree starts from the tile's level")
    stop = zhi if part is None or part.last is None else min(zhi, part.last)
    split = part is not None and part.split is not None
    tasks = []  # a split run's: (tile, forced class, its one-cell level, last zoom)
    for lev in driver.walk(cells, stop, start=start):
        if len(lev.cells) == 0:
            break
        root = part is not None and part.root is not None and lev.level == part.root[0]
        if not split:
            job.run(lev, chain, (zlo, zhi), max_block, root=root, final=lev.level >= stop)
            continue
        # a split run writes the decided tiles; the others become tasks: the frontier
        # tiles above the split zoom one by one, the kept tiles of the split zoom with
        # their subtrees
        chosen = job.choose(lev)
        at = part.split_at(lev)
        front = job.run(lev, chain, (zlo, zhi), max_block, chosen=chosen, kept_too=at)
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


class MemoryStore:
    """A tile store that keeps the tiles of a task: ``groups`` maps each distinct image
    (its bytes) to the XYZ tiles that have it."""

    def __init__(self):
        self.groups: dict[bytes, list] = {}

    def existing(self) -> set:
        return set()

    def put(self, z: int, x: int, y: int, data: bytes) -> None:
        self.put_many([(z, x, y)], data)

    def put_many(self, tiles, data: bytes) -> None:
        self.groups.setdefault(data, []).extend((int(z), int(x), int(y)) for z, x, y in tiles)

    def commit(self) -> None:
        pass


def subpyramid(
    job, root, have, start: Level | None = None, last: int | None = None
) -> tuple[list, PyramidStats]:
    """The tile ``root`` (``(z, x, y)``) of the pyramid ``job`` and its descendants down
    to zoom ``last`` (default: the pyramid's deepest), as ``[(tiles, image)]``, and the
    task's counts; ``have``: tiles to skip (a resumed output's)."""
    shape, d, zlo, zhi, size, style, max_block = job
    keep_freed_memory()
    store = MemoryStore()
    stats = PyramidStats()
    part = Part(root=root, start=start, last=last)
    run_pyramid(shape, d, zlo, zhi, size, style, store, have, None, max_block, stats, part=part)
    return [(tiles, data) for data, tiles in store.groups.items()], stats


class _Zoom:
    """What a zoom of the pyramid writes: fully inside tiles and their descendants (one
    shared image), decided tiles with an outline (drawn), frontier tiles (rendered)."""

    def __init__(self, cells, style, store, have, size, stats, track):
        self.cells, self.style, self.store, self.have = cells, style, store, have
        self.size, self.stats, self.track = size, stats, track
        self.full = style.encode(np.ones((size, size), dtype=bool))
        self.outline = OutlineArcs(cells.arcs) if style.outline is not None else None

    def lines_of(self, lev: Level, i: int, r):
        """The outline's lines in tile ``i`` of ``lev``."""
        if self.outline is None:
            return ()
        f, arcs = lev.state, self.cells.arcs
        s, t = np.searchsorted(f.pair_cell, [i, i + 1])
        cand = f.pair_arc[s:t]
        cand = cand[arcs.boundary[cand]]
        y, x = (int(v) for v in f.cells[i])
        return self.outline.lines(cand, f.centers[i], float(r[i]), lev.level, x, y, self.size)

    def run(
        self,
        lev: Level,
        chain,
        zooms: tuple[int, int],
        max_block: int,
        *,
        root: bool = False,
        chosen=None,
        kept_too: bool = False,
        final: bool = False,
    ):
        """Write the zoom's tiles and choose the cells refined next (``lev.keep``).

        ``root``: the level is a task's root tile, whose zoom the split counted.
        ``chosen``: a split run's zoom, :meth:`choose` made: the frontier tiles are
        returned, not rendered (with ``kept_too``, the outlined tiles are not drawn
        either). ``final``: the run's last zoom."""
        (zlo, zhi), z, cls, stats = zooms, lev.level, lev.cls, self.stats
        defer = chosen is not None
        r, carry = chosen if defer else self.choose(lev)
        cont = np.flatnonzero((cls == CONTAINED) & ~carry)
        front = np.flatnonzero(cls == FRONTIER)
        paint = np.flatnonzero(carry)
        zs = {
            "contained": int(len(cont)),
            "outside": int(((cls == OUTSIDE) & ~carry).sum()),
            "frontier": int(len(front)),
        }
        if not root:
            stats.zooms[z] = zs
        if z >= zlo:
            stats.outside += zs["outside"]
        # the bin levels below the frontier tiles: rendering needs them from zoom min on,
        # the estimate of the tiles to come from the zoom before (a split run renders
        # nothing: its tasks make their own)
        ahead = z >= zlo - 1 and not defer and not (final and self.alone(z))
        if ahead:
            chain.advance(subset(lev.state, front))
        self.track.plan(
            z,
            front=len(front),
            contained=len(cont),
            carried_in=int((cls[paint] == CONTAINED).sum()),
            carried_out=int((cls[paint] == OUTSIDE).sum()),
            ahead=chain.counts() if ahead else [],
        )
        self.inside(lev, cont, zlo, zhi)
        if z >= zlo:
            if not kept_too:
                self.painted(lev, paint, r)
            if not defer:
                self.rendered(lev, front, r, chain, max_block)
            self.store.commit()
        return front if z >= zlo else front[:0]

    def choose(self, lev: Level):
        """The cells refined next (``lev.keep``: frontier tiles, and decided tiles an
        outline crosses, whose children inherit the class: ``lev.forced``); returns the
        zoom's decision radii and which tiles are carried so."""
        cls = lev.cls
        r = self.cells.grid.decision_rho(lev.level, lev.cells[:, 0])
        carry = (cls != FRONTIER) & (lev.measure <= r)
        if self.outline is None:
            carry[:] = False
        lev.keep = np.flatnonzero((cls == FRONTIER) | carry)
        lev.forced = np.where(carry, cls, NOT_FORCED).astype(np.uint8)[lev.keep]
        return r, carry

    def alone(self, z: int) -> bool:
        """Whether the frontier tiles of zoom ``z`` are rendered one by one (without
        the bin chain)."""
        return z <= PYRAMID_ALONE_ZOOM and self.outline is None

    def inside(self, lev: Level, cont, zlo: int, zhi: int):
        """Fully inside: the tiles ``cont`` and all their descendants, one shared image."""
        stats = self.stats
        rows, cols = lev.cells[:, 0], lev.cells[:, 1]
        with self.track.light():
            for i in cont:
                for zz, xs, ys in _subtree(int(cols[i]), int(rows[i]), lev.level, zlo, zhi):
                    tiles = [(zz, int(x), int(y)) for x, y in zip(xs, ys)]
                    if self.have:
                        new = [t for t in tiles if t not in self.have]
                        stats.present += len(tiles) - len(new)
                        tiles = new
                    if self.full is not None and tiles:
                        self.store.put_many(tiles, self.full)
                    stats.inside += len(tiles)
                    self.track.tick(light=len(xs), skipped=len(xs) - len(tiles))

    def painted(self, lev: Level, paint, r):
        """Decided tiles with an outline: drawn, not rendered."""
        z, rows, cols = lev.level, lev.cells[:, 0], lev.cells[:, 1]
        for i in paint:
            key = (z, int(cols[i]), int(rows[i]))
            if key in self.have:
                self.stats.present += 1
                self.track.tick(heavy=1, skipped=1)
                continue
            mask = np.full((self.size, self.size), lev.cls[i] == CONTAINED)
            data = self.style.encode(mask, self.lines_of(lev, i, r))
            if data is not None:
                self.store.put(*key, data)
                self.stats.painted += 1
            self.track.tick(heavy=1)

    def rendered(self, lev: Level, front, r, chain, max_block: int):
        """Frontier tiles: their frontier bins rendered in batches, from the chain."""
        z, rows, cols, stats = lev.level, lev.cells[:, 0], lev.cells[:, 1], self.stats
        todo = [k for k, i in enumerate(front) if (z, int(cols[i]), int(rows[i])) not in self.have]
        stats.present += len(front) - len(todo)
        self.track.tick(heavy=len(front) - len(todo), skipped=len(front) - len(todo))
        if todo:
            self.track.setup(_gl_passes)  # the GL context, once: not a tile's cost
        if self.alone(z):
            # few tiles, each far coarser than the input: one render per tile, from the
            # curves simplified to its pixels where that pays (as render_tiles does)
            shape, d, size = self.cells.shape, self.cells.d, self.size
            masks = (
                (
                    k,
                    render_grid(shape, d, _tile(z, int(cols[front[k]]), int(rows[front[k]]), size))
                    > 0,
                )
                for k in todo
            )
        else:
            masks = _render_tiles(
                chain, np.asarray(todo, dtype=np.int64), self.size, max_block, stats
            )
        for k, mask in masks:
            i = front[k]
            data = self.style.encode(mask, self.lines_of(lev, i, r))
            stats.rendered += 1
            if data is None:
                stats.empty += 1
            else:
                self.store.put(z, int(cols[i]), int(rows[i]), data)
            self.track.tick(heavy=1)


def _gl_passes():
    from ...gl.vector_pass import vector_passes

    return vector_passes()


def _keys(cells: np.ndarray, k: int = 0) -> np.ndarray:
    """Sort keys of the ancestors ``k`` levels up of ``cells`` (row-major order)."""
    return ((cells[:, 0] >> k) << 32) | (cells[:, 1] >> k)


def _member(keys: np.ndarray, sorted_keys: np.ndarray) -> np.ndarray:
    """Positions of ``keys`` in ``sorted_keys`` (-1 where absent)."""
    if len(sorted_keys) == 0:
        return np.full(len(keys), -1)
    pos = np.minimum(np.searchsorted(sorted_keys, keys), len(sorted_keys) - 1)
    return np.where(sorted_keys[pos] == keys, pos, -1)


class _BinChain:
    """The levels between the frontier tiles of a zoom and their bins, kept from zoom
    to zoom.

    For the frontier tiles of zoom ``z`` (``size = 2^P`` pixels, bins of 16) the
    levels ``z + 1 .. z + nb`` (``nb = P - 4``) hold, per level, the decided cells
    with their classes and the :class:`~gloffset.raster.levels.Frontier` of the others,
    all in float64 with the decision rules of :mod:`gloffset.raster.levels` and the
    bound :meth:`~gloffset.grids.mercator.TilePyramid.decision_rho`. The frontier tiles
    of zoom ``z + 1`` are frontier
    cells of level ``z + 1`` here, so their levels ``z + 2 .. z + nb`` are already
    known: advancing a zoom filters them and computes one new level.
    """

    def __init__(self, cells: CurveCells, nb: int):
        self.cells, self.levels, self.nb = cells, cells.grid, nb
        self.arcs, self.d = cells.arcs, cells.d
        self.z = None
        self.lev = []  # per level z + 1 + i: (decided cells, their classes, Frontier)

    def _next(self, f):
        """Level ``f.level + 1``: the children of ``f``'s cells, classified."""
        every = np.full(len(f.cells), FRONTIER, dtype=np.uint8)
        lev = self.cells.refine(Level(f.level, f.cells, every, f))
        dec = np.flatnonzero(lev.cls != FRONTIER)
        return lev.cells[dec], lev.cls[dec], subset(lev.state, lev.frontier())

    def advance(self, f):
        """Make the chain that of the tiles of ``f`` (frontier tiles of zoom ``f.level``)."""
        keys = _keys(f.cells)
        if self.z is not None and self.z + 1 == f.level and self.nb > 1:
            lev = []
            for k, (dc, dcls, fr) in enumerate(self.lev[1:], start=1):
                keep = _member(_keys(dc, k), keys) >= 0
                inner = np.flatnonzero(_member(_keys(fr.cells, k), keys) >= 0)
                lev.append((dc[keep], dcls[keep], subset(fr, inner)))
            lev.append(self._next(lev[-1][2]))
        else:
            lev, cur = [], f
            for _ in range(self.nb):
                lev.append(self._next(cur))
                cur = lev[-1][2]
        self.z, self.lev, self.f = f.level, lev, f

    def counts(self) -> list[tuple[int, int]]:
        """``(frontier, contained)`` cells of each level ``z + 1 .. z + nb`` of the chain:
        the frontier and newly contained tiles of those zooms (without an outline)."""
        return [(len(fr.cells), int((dcls == CONTAINED).sum())) for _, dcls, fr in self.lev]

    def layout(self, which, ns):
        """The tiles ``which`` (indices into the chain's tiles) down to their bins.

        Returns the bin-level classes of each tile ((n, 2^nb, 2^nb), every decided cell
        painted), the :class:`~gloffset.raster.layout.BinLayout` of the frontier bins
        (``ns`` GPU levels below them), their :class:`~gloffset.raster.levels.Frontier`,
        and each frontier bin's tile (position in ``which``) and place in it."""
        nb = self.nb
        nbin = 1 << nb
        tiles = np.zeros((len(which), nbin, nbin), dtype=np.uint8)
        keys = _keys(self.f.cells[which])
        order = np.argsort(keys)
        tkeys = keys[order]  # the batch's tiles, sorted

        def place(cells, k):
            t = _member(_keys(cells, k), tkeys)
            sel = np.flatnonzero(t >= 0)
            m = (1 << k) - 1
            return sel, order[t[sel]], cells[sel, 0] & m, cells[sel, 1] & m

        if nb == 0:
            fb = subset(self.f, np.sort(np.asarray(which)))
        for k, (dc, dcls, fr) in enumerate(self.lev, start=1):
            sel, t, jr, jc = place(dc, k)
            span = 1 << (nb - k)  # bins per side of a cell of this level
            dd = np.arange(span)
            rr = (jr * span)[:, None, None] + dd[None, :, None]
            cc = (jc * span)[:, None, None] + dd[None, None, :]
            tiles[t[:, None, None], rr, cc] = dcls[sel][:, None, None]
            if k == nb:
                fb = subset(fr, place(fr.cells, k)[0])
        _, t, jr, jc = place(fb.cells, nb)
        tiles[t, jr, jc] = FRONTIER
        zb = self.f.level + nb
        layout = BinLayout.build(
            fb.cells,
            ns,
            ns,
            lambda s, rows: self.levels.decision_rho(zb + s, rows),
            lambda s, rows: self.levels.tile_lat(zb + s, rows + 0.5),
            lambda s, cols: self.levels.tile_lon(zb + s, cols + 0.5),
        )
        return tiles, layout, fb, (t, jr, jc)


@functools.lru_cache(maxsize=64)
def _pyramid(maxzoom: int, ell=None) -> TilePyramid:
    """The :class:`TilePyramid` down to ``maxzoom`` (on the conformal sphere of ``ell``),
    made once (its bounds per zoom)."""
    return TilePyramid(maxzoom, ell)


#: zooms up to which :func:`render_tiles` renders each tile on its own grid
#: (:func:`gloffset.render` on a :class:`~gloffset.grids.Tile`), not with the pyramid's
#: levels: 2-5 times faster there (measured, Mexico and countries_10m), slower below (z4
#: on), where the levels also batch the tiles
ALONE_ZOOM = 3


#: zooms up to which a pyramid renders each frontier tile on its own grid (as
#: :func:`render_tiles` does up to :data:`ALONE_ZOOM`): there the pyramid's bins hold
#: thousands of arcs each and a tile's own render, from the simplified curves, is 1.5-2.6
#: times faster (countries_10m, zooms 0-2); from zoom 3 on the batched levels are faster
PYRAMID_ALONE_ZOOM = 2


@functools.lru_cache(maxsize=1024)
def _tile(z: int, x: int, y: int, size: int) -> Tile:
    """The :class:`~gloffset.grids.Tile`, made once: it keeps its levels' bounds and
    geometry, the same for every distance (zooms 0-3 have 85 tiles)."""
    return Tile(z, x, y, size)


@dataclass(frozen=True)
class TileCentre:
    """What decides a tile wholly inside or outside at any distance: the exact distances
    from its centre to the nearest boundary arc (``dist``) and ring edge (``dring``),
    whether the centre is inside, and the tile's rigorous bound ``rho`` (1-element arrays,
    as :func:`gloffset.raster.levels.decide` takes them). None of it depends on the
    offset distance, so a tile server measures it once per tile."""

    dist: np.ndarray
    dring: np.ndarray
    inside: np.ndarray
    rho: np.ndarray

    def decide(self, d: float):
        """CONTAINED or OUTSIDE when every pixel of the tile is so at distance ``d``
        (radians), else None (the raster levels' rule at the tile's own zoom)."""
        cls = int(decide(self.dist, self.dring, self.inside, self.rho, d, False)[0])
        return cls if cls in (CONTAINED, OUTSIDE) else None


def measure_tiles(shape, z: int, tiles) -> dict:
    """The :class:`TileCentre` of each tile ``(x, y)`` of zoom ``z``, measured together:
    the tiles entered directly at their zoom (:func:`gloffset.raster.levels.at_cells`)
    with every arc that can be a centre's nearest as candidates (no distance limit)."""
    grid = _pyramid(z)
    arcs = CurveArcs.from_shape(shape)
    f = at_cells(shape, arcs, grid, math.pi, z, [(y, x) for x, y in tiles])
    dist, dring = cell_distances(f, arcs)
    inside, rho = inside_any(f.status), grid.decision_rho(z, f.cells[:, 0])
    return {
        (int(x), int(y)): TileCentre(
            dist[i : i + 1], dring[i : i + 1], inside[i : i + 1], rho[i : i + 1]
        )
        for i, (y, x) in enumerate(f.cells)
    }


def render_tiles(
    shape,
    d: float,
    z: int,
    tiles,
    *,
    size: int = 256,
    style=None,
    max_block=MAX_BLOCK,
    alone_zoom: int = ALONE_ZOOM,
):
    """The styled PNG bytes of tiles ``(x, y)`` of zoom ``z`` (None where a tile has
    nothing to draw), the pixels those of a pyramid and of :func:`gloffset.render` on
    :class:`~gloffset.grids.Tile`; ``d`` in radians.

    The work follows the tiles, not the input: the tiles are classified directly at
    zoom ``z`` (their candidate arcs from the cap tree, within their reach:
    :meth:`~gloffset.raster.curves.CurveCells.enter_cells`), a tile decided contained or
    outside is answered at once, and the frontier tiles are rendered together in
    batched GPU runs. Up to zoom ``alone_zoom`` (:data:`ALONE_ZOOM`), where that is
    slower, each tile is rendered on its own :class:`~gloffset.grids.Tile` (no outline).
    """
    style = style if style is not None else TileStyle()
    want = sorted({(int(x), int(y)) for x, y in tiles})
    if z <= alone_zoom and style.outline is None:
        return {
            (x, y): style.encode(render(shape, d, _tile(z, x, y, size), radius=1.0) > 0)
            for x, y in want
        }
    plog = size.bit_length() - 1
    cells = CurveCells(shape, d, _pyramid(z + plog))
    chain = _BinChain(cells, max(0, plog - _BIN_LOG2))
    stats = PyramidStats()
    job = _Zoom(cells, style, MemoryStore(), set(), size, stats, _Tracker(z, z, None))
    lev = cells.enter_cells(z, [(y, x) for x, y in want])
    rows, cols, cls = lev.cells[:, 0], lev.cells[:, 1], lev.cls
    r = cells.grid.decision_rho(z, rows)
    out = {}

    def keep(i, mask):
        lines = job.lines_of(lev, i, r) if mask is not None or lev.measure[i] <= r[i] else ()
        if mask is None:  # decided: the one image of its class unless an outline crosses
            if not len(lines):
                out[(int(cols[i]), int(rows[i]))] = job.full if cls[i] == CONTAINED else None
                return
            mask = np.full((size, size), cls[i] == CONTAINED)
        out[(int(cols[i]), int(rows[i]))] = style.encode(mask, lines)

    for i in np.flatnonzero(cls != FRONTIER):
        keep(i, None)
    front = np.flatnonzero(cls == FRONTIER)
    if len(front):
        chain.advance(subset(lev.state, front))
        which = np.arange(len(front), dtype=np.int64)
        for k, mask in _render_tiles(chain, which, size, max_block, stats):
            keep(front[k], mask)
    return {t: out.get(t) for t in want}


def tile_masks(
    shape, d: float, z: int, tiles, *, size: int = 256, ell=None, alone_zoom: int = ALONE_ZOOM
) -> dict:
    """The masks (bool, ``size x size``) of tiles ``(x, y)`` of zoom ``z`` at ``d``
    (radians), the pixels of :func:`gloffset.render` on their :class:`~gloffset.grids.Tile`,
    by the route of :func:`render_tiles` (decided tiles answered at once, frontier tiles
    rendered in batched GPU runs). ``ell``: the tiles' latitudes are geodetic latitudes
    of that ellipsoid and ``shape`` lies on its conformal sphere (each pixel is the
    spherical answer at the conformal image of its centre,
    :class:`~gloffset.grids.conformal.ConformalRows`)."""
    want = sorted({(int(x), int(y)) for x, y in tiles})
    if z <= alone_zoom:
        out = {}
        for x, y in want:
            grid = _tile(z, x, y, size)
            if ell is not None:
                grid = ConformalRows(grid, ell)
            out[(x, y)] = render_grid(shape, d, grid) > 0
        return out
    plog = size.bit_length() - 1
    cells = CurveCells(shape, d, _pyramid(z + plog, ell))
    chain = _BinChain(cells, max(0, plog - _BIN_LOG2))
    lev = cells.enter_cells(z, [(y, x) for x, y in want])
    rows, cols, cls = lev.cells[:, 0], lev.cells[:, 1], lev.cls
    out = {}
    for i in np.flatnonzero(cls != FRONTIER):
        out[(int(cols[i]), int(rows[i]))] = np.full((size, size), cls[i] == CONTAINED)
    front = np.flatnonzero(cls == FRONTIER)
    if len(front):
        chain.advance(subset(lev.state, front))
        which = np.arange(len(front), dtype=np.int64)
        for k, mask in _render_tiles(chain, which, size, MAX_BLOCK, PyramidStats()):
            i = front[k]
            out[(int(cols[i]), int(rows[i]))] = mask
    return {t: out[t] for t in want}


def _render_tiles(chain, which, size, max_block, stats):
    """Masks of the frontier tiles ``which`` (indices into the chain's tiles), as
    ``(index, mask)``: the GPU levels classify the frontier bins of up to
    ``(max_block / size)^2`` tiles per run, packed into one small canvas; every other
    pixel of a tile is its bin's class."""
    from ..gpu import bin_passes

    plog = size.bit_length() - 1
    ns = plog - chain.nb  # GPU levels: a bin is 2^ns pixels on a side
    b = 1 << ns
    per_run = max(1, max_block // size) ** 2
    for s0 in range(0, len(which), per_run):
        batch = which[s0 : s0 + per_run]
        tiles, layout, fb, (t, jr, jc) = chain.layout(batch, ns)
        packed = bin_passes().run_layout(layout, chain.d, fb, chain.arcs)
        stats.render_calls += 1
        n, nbin = len(batch), tiles.shape[1]
        out = np.repeat(np.repeat(tiles, b, 1), b, 2)
        view = out.reshape(n, nbin, b, nbin, b).transpose(0, 1, 3, 2, 4)
        view[t, jr, jc] = layout.blocks(packed)
        for k, i in enumerate(batch):
            yield int(i), out[k] == CONTAINED
