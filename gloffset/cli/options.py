"""Options shared by several subcommands."""

from __future__ import annotations

import os
import sys
import time
from typing import Any

import click

from ..ellipsoid import ELLIPSOIDS, as_ellipsoid
from ..errors import InvalidDistanceError, InvalidEllipsoidError, OptionError
from ..units import EARTH_RADIUS, parse_distance, to_metres


def distance_option(f=None, *, default: str | None = None, many: bool = False):
    """``-d/--distance``, required unless a ``default`` is given (``@distance_option`` or
    ``@distance_option(default="0")``); ``many``: the help says a list is taken
    (:func:`distance_list`)."""

    def decorate(f):
        # no default=None for a required option: recent click (8.5) takes an explicit None
        # as a default value and no longer reports the option as missing
        given: dict[str, Any] = (
            {"default": default, "show_default": True} if default is not None else {}
        )
        return click.option(
            "-d",
            "--distance",
            required=default is None,
            metavar="DIST",
            help="Offset distance: 500m, 127km, 0.02rad, 1.5deg (a bare number is metres). "
            "Negative shrinks polygons."
            + (" Several, comma-separated (10km,50km): one output per distance." if many else ""),
            **given,
        )(f)

    return decorate(f) if f is not None else decorate


def distance_list(text: str, convert) -> list[tuple[str, float]]:
    """``-d 10km,50km,127km``: each distance as given and its value by ``convert`` (the
    angle or the metres), refused (:class:`~gloffset.errors.InvalidDistanceError`) with an
    empty item, a bad one or one given twice."""
    items = [t.strip() for t in str(text).split(",")]
    if len(items) > 1 and not all(items):
        raise InvalidDistanceError(
            f"-d {text!r} has an empty item: give distances separated by single commas, "
            "e.g. 10km,50km,127km"
        )
    out: list[tuple[str, float]] = []
    seen: dict[float, str] = {}
    for item in items:
        value = convert(item)
        if value in seen:
            raise InvalidDistanceError(
                f"-d {text!r} gives the distance {item} twice (as {seen[value]} before)"
            )
        seen[value] = item
        out.append((item, value))
    return out


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


def measure_options(f=None, *, default: str | None = None, many: bool = False):
    """``-d/--distance``, ``--radius`` and ``--ellipsoid``, in this order: the distance and
    the sphere or ellipsoid it is measured on (``@measure_options`` or
    ``@measure_options(default="0")``, the default of ``-d``; ``many``: a list of distances
    is taken, :func:`distance_list`); :func:`measure` reads them."""

    def decorate(f):
        return distance_option(default=default, many=many)(radius_option(ellipsoid_option(f)))

    return decorate(f) if f is not None else decorate


def measure(distance: str, radius: float, ellipsoid: str | None) -> tuple:
    """The options of :func:`measure_options` checked, before the work: ``(None, angle)``
    on the sphere of ``radius`` (the angle in radians, as :func:`angle`), or ``(ell,
    metres)`` with ``--ellipsoid`` (an Ellipsoid and a geodesic length, as :func:`metres`).
    Raises InvalidEllipsoidError or InvalidDistanceError naming the bad value."""
    ell = parse_ellipsoid(ellipsoid)
    return ell, (angle(distance, radius) if ell is None else metres(distance))


def ellipsoid_option(f):
    """``--ellipsoid NAME`` (WGS84, GRS80) or ``--ellipsoid A,F``."""
    return click.option(
        "--ellipsoid",
        default=None,
        metavar="NAME|A,F",
        help=f"Measure on an ellipsoid ({', '.join(ELLIPSOIDS)}, or semi-major axis and "
        "flattening as A,F): geodesic distances in metres, geodetic latitudes, geodesic "
        "edges. Default: the sphere of --radius.",
    )(f)


def parse_ellipsoid(text: str | None):
    """The ``--ellipsoid`` value as an Ellipsoid (None without it)."""
    if text is None:
        return None
    if "," in text:
        try:
            a, f = (float(x) for x in text.split(","))
        except ValueError:
            raise InvalidEllipsoidError(
                f"--ellipsoid {text!r}: expected a name ({', '.join(ELLIPSOIDS)}) or A,F"
            ) from None
        return as_ellipsoid((a, f))
    return as_ellipsoid(text)


def metres(text: str) -> float:
    """A CLI distance as a length in metres (for --ellipsoid: no angle units)."""
    return to_metres(text)


def number_option(*names: str, low: float, default: float, help: str):
    """An option taking a number of at least ``low`` (an integer when ``default`` is an
    int, else a float), its default shown in ``--help``."""
    kind = click.IntRange(min=int(low)) if isinstance(default, int) else click.FloatRange(min=low)
    return click.option(*names, type=kind, default=default, show_default=True, help=help)


def choice_option(*names: str, choices: tuple[str, ...], help: str | None = None):
    """An option taking one of ``choices``, the first by default (shown in ``--help``)."""
    return click.option(
        *names, type=click.Choice(choices), default=choices[0], show_default=True, help=help
    )


def input_options(f):
    """``--layer`` and ``--where``: which layer and features of a vector file to read;
    ``--densify``: the tolerance of the edges of a file in a projected CRS."""
    f = click.option(
        "--densify",
        default=None,
        metavar="DIST",
        help="For a vector file in a projected CRS (EPSG:3857, UTM...): follow its edges, "
        "straight in the projection, to within DIST (e.g. 0.1m; a bare number is metres; at "
        "least 0.001m). "
        "Default: 1 m or a hundredth of the edge, whichever is smaller. Lon/lat edges are "
        "great circles and are kept as they are.",
    )(f)
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


def fill_options(default: str | None, what: str = "the region"):
    """``--fill COLOUR`` and ``--opacity 0..1`` (multiplies the fill's alpha): one style
    for ``render``, ``tiles`` and ``serve``'s query (``fill``, ``opacity``)."""

    def deco(f):
        f = click.option(
            "--opacity",
            type=click.FloatRange(0.0, 1.0),
            default=1.0,
            show_default=True,
            help="Opacity of the fill, 0..1 (multiplies the colour's own alpha).",
        )(f)
        return click.option(
            "--fill",
            default=default,
            show_default=default is not None,
            metavar="COLOUR",
            help=f"Colour of {what}: '#rrggbb', '#rrggbbaa' or 'r,g,b[,a]'.",
        )(f)

    return deco


#: ``GLOFFSET_PROGRESS=1`` shows progress on stderr even when it is not a terminal (logs,
#: tests), ``=0`` never; unset: on a terminal only.
PROGRESS_ENV = "GLOFFSET_PROGRESS"


def show_progress() -> bool:
    """Whether a long command shows its progress on stderr: on a terminal, unless
    :data:`PROGRESS_ENV` says otherwise."""
    forced = os.environ.get(PROGRESS_ENV, "").strip()
    if forced in ("0", "1"):
        return forced == "1"
    return sys.stderr.isatty()


def progress_bar(**options):
    """A tqdm bar on stderr (``options``: tqdm's) where :func:`show_progress`, else None."""
    if not show_progress():
        return None
    from tqdm import tqdm

    return tqdm(file=sys.stderr, dynamic_ncols=True, **options)


class Stages:
    """The stages of a long vector command on one stderr line (tqdm): the stage, how
    many of a stage's items are done, and the time so far; nothing unless
    :func:`show_progress`. Use as a context manager, calling :meth:`stage` as each stage
    begins and :meth:`tick` after each item of a stage with items."""

    def __init__(self, n_stages: int):
        self.bar = progress_bar(total=n_stages, bar_format="{desc} [{elapsed}]")
        self.name, self.items, self.done, self.shown = "", 0, 0, 0.0

    def stage(self, name: str, items: int = 0) -> None:
        """Begin stage ``name`` (``items``: how many items it handles, 0 for none)."""
        if self.bar is None:
            return
        if self.name:
            self.bar.update(1)
        self.name, self.items, self.done = name, items, 0
        self._show(force=True)

    def tick(self) -> None:
        """One more item of the current stage done."""
        if self.bar is None:
            return
        self.done += 1
        self._show(force=self.done == self.items)

    def _show(self, force: bool) -> None:
        assert self.bar is not None  # the callers return without a bar
        now = time.monotonic()
        if not force and now - self.shown < 0.1:
            return
        self.shown = now
        count = f" {self.done:,}/{self.items:,}" if self.items else ""
        step = f"{self.bar.n + 1}/{self.bar.total}"
        self.bar.set_description_str(f"{step} {self.name}{count}", refresh=False)
        self.bar.refresh()

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        if self.bar is not None:
            if exc[0] is None:
                self.bar.update(self.bar.total - self.bar.n)
                self.bar.set_description_str("done", refresh=False)
            self.bar.close()


def size_options(f):
    """``--size`` (WIDTHxHEIGHT, or N for a cube face) and ``--bounds`` (W,S,E,N) of an
    image; :func:`parse_size`, :func:`parse_face` and :func:`parse_bounds` read them."""
    f = click.option(
        "--bounds",
        default=None,
        help="W,S,E,N in degrees (W > E crosses 180 deg). Default: the globe.",
    )(f)
    return click.option(
        "--size",
        default=None,
        help="WIDTHxHEIGHT in pixels (default 4096x2048); for cube the face side N.",
    )(f)


def crs_option(f):
    """``--crs`` of an image in a projected CRS (:class:`gloffset.grids.Projected`)."""
    return click.option(
        "--crs",
        default=None,
        metavar="CRS",
        help="A projected CRS pyproj knows (EPSG:3031, EPSG:3413, a UTM zone, WKT, PROJ): the "
        "image is in it, --bounds XMIN,YMIN,XMAX,YMAX are its outer edges in its units "
        "(default: the CRS's area of use, projected) and --size defaults to 2048x2048. "
        "Pixels outside the projection's domain are outside.",
    )(f)


def projected_grid(crs: str, size: str | None, bounds: str | None):
    """The :class:`~gloffset.grids.Projected` grid of ``--crs``, ``--size`` and ``--bounds``
    (XMIN,YMIN,XMAX,YMAX in the CRS's units)."""
    from ..grids import Projected

    w, h = parse_size(size or "2048x2048")
    b = None
    if bounds is not None:
        try:
            b = tuple(float(v) for v in bounds.split(","))
        except ValueError:
            b = ()
        if len(b) != 4:
            raise OptionError(
                "--bounds with --crs must be XMIN,YMIN,XMAX,YMAX in the CRS's units, "
                f"got {bounds!r}"
            )
    return Projected(w, h, crs=crs, bounds=b)


def projected_georef(grid, description: str | None):
    """The :class:`~gloffset.io.georef.Georef` of a Projected grid: its transform, its CRS
    (EPSG code, else WKT) and the ESRI WKT of a ``.prj``."""
    from ..io.georef import Georef

    code = grid.crs.to_epsg()
    name = f"EPSG:{code}" if code is not None else grid.crs.to_wkt()
    try:
        prj = grid.crs.to_wkt("WKT1_ESRI")
    except Exception:  # a CRS without an ESRI form: the OGC WKT
        prj = grid.crs.to_wkt("WKT1_GDAL")
    return Georef(grid.transform(), crs=name, description=description, prj=prj)


def parse_size(text: str) -> tuple[int, int]:
    """``--size WIDTHxHEIGHT`` as ``(width, height)``."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise OptionError(f"--size must be WIDTHxHEIGHT, e.g. 4096x2048, got {text!r}") from None
    return w, h


def parse_face(text: str) -> int:
    """``--size N`` (or ``NxN``) of a cube: the face side."""
    parts = text.lower().split("x")
    try:
        vals = {int(v) for v in parts}
    except ValueError:
        vals = set()
    if len(vals) != 1 or len(parts) > 2:
        raise OptionError(f"--size for a cube is the face side N (or NxN), got {text!r}")
    return vals.pop()


def parse_bounds(text: str | None) -> tuple:
    """``--bounds W,S,E,N`` in degrees (the globe without it)."""
    if text is None:
        return (-180.0, -90.0, 180.0, 90.0)
    try:
        vals = tuple(float(v) for v in text.split(","))
    except ValueError:
        vals = ()
    if len(vals) != 4:
        raise OptionError(f"--bounds must be W,S,E,N in degrees, got {text!r}")
    return vals
