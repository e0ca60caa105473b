"""``gloffset contains``: which points of a CSV file lie in the offset region (streamed)."""

from __future__ import annotations

import csv
import io
import os
import sys
from collections.abc import Callable

import click
import numpy as np

from ..ellipsoidal import contains as ellipsoidal_contains
from ..errors import InputFormatError
from ..index.contains import depth_for
from ..index.tree import Index
from ..io.features import features, load
from ..io.output import check_output, open_output
from ..shape import read
from ..units import first_not_finite
from . import main
from .options import input_options, measure, measure_options, number_option, progress_bar

#: Accepted names of the coordinate columns (case-insensitive).
LON_NAMES = ("lon", "lng", "long", "longitude")
LAT_NAMES = ("lat", "latitude")


def _column(header: list[str], names: tuple[str, ...], where: str) -> int:
    lowered = [h.strip().lower() for h in header]
    for name in names:
        if name in lowered:
            return lowered.index(name)
    raise InputFormatError(
        f"{where}: no {names[0]!r} column in the header (found: {', '.join(header) or 'nothing'}); "
        f"name the coordinate columns lon and lat"
    )


def _coordinates(rows, lines, width: int, ilon: int, ilat: int, where: str):
    """Lon/lat arrays of a chunk of rows of ``width`` fields; an error names the first bad
    line (a field that is no number, not finite, a latitude outside [-90, 90] or a
    longitude outside [-180, 180], as GeoJSON's are refused: never wrapped)."""
    for r, line in zip(rows, lines):
        if len(r) != width:
            raise InputFormatError(
                f"{where}, line {line}: {len(r)} field{'s' if len(r) != 1 else ''}, but the "
                f"header has {width}"
            )
    try:
        lon = np.array([r[ilon] for r in rows], dtype=np.float64)
        lat = np.array([r[ilat] for r in rows], dtype=np.float64)
    except ValueError:
        for r, line in zip(rows, lines):
            for k, name in ((ilon, "lon"), (ilat, "lat")):
                try:
                    float(r[k])
                except ValueError:
                    raise InputFormatError(
                        f"{where}, line {line}: {name} {r[k]!r} is not a number"
                    ) from None
        raise  # pragma: no cover  (some row failed above)
    nonfinite = first_not_finite(lon, lat)
    if nonfinite is not None:
        raise InputFormatError(
            f"{where}, line {lines[nonfinite]}: coordinates must be finite, got "
            f"{float(lon[nonfinite])!r}, {float(lat[nonfinite])!r}"
        )
    for values, name, limit in ((lat, "latitude", 90.0), (lon, "longitude", 180.0)):
        bad = np.abs(values) > limit
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise InputFormatError(
                f"{where}, line {lines[k]}: {name} {float(values[k])!r} out of range "
                f"[-{limit:g}, {limit:g}]"
            )
    return lon, lat


def _position(src) -> int | None:
    """Bytes read so far from a file (ahead of the rows parsed by a buffer's size)."""
    try:
        return src.buffer.tell()
    except (AttributeError, OSError):
        return None


def _chunks(reader, size: int):
    """Lists of (row, line number), ``size`` rows at a time."""
    rows, lines = [], []
    for row in reader:
        if not row:  # blank line
            continue
        rows.append(row)
        lines.append(reader.line_num)
        if len(rows) >= size:
            yield rows, lines
            rows, lines = [], []
    if rows:
        yield rows, lines


@main.command("contains")
@click.argument("input", metavar="INPUT")
@click.argument("points", metavar="POINTS")
@measure_options(default="0")
@click.option(
    "-o", "--output", default="-", show_default=True, help="Output CSV file, - for stdout."
)
@click.option(
    "--level",
    type=int,
    default=None,
    help="Decomposition level of the candidate arcs (default: chosen).",
)
@number_option("--chunk", low=1, default=100_000, help="Rows per batch.")
@input_options
@click.option(
    "--each",
    is_flag=True,
    help="Test each feature of INPUT on its own: a row per point and feature it lies in, "
    "with the feature's index and properties.",
)
def contains_cmd(
    input, points, distance, radius, ellipsoid, output, level, chunk, layer, where, densify, each
):
    """Mark the points of POINTS (CSV with lon and lat columns in degrees, - for stdin) that
    lie in the region within DIST of the curves and polygons of INPUT (GeoJSON or another
    vector file).

    The output repeats every row with a column 'inside' (true or false). With --each, a
    point is written once per feature whose region it lies in, with the columns 'feature'
    (the feature's 0-based index) and the feature's properties, and once with 'inside'
    false if it lies in none. Large files are read and written in batches; a progress bar
    shows on a terminal. With --ellipsoid, DIST is a geodesic length on that ellipsoid
    and polygon edges are geodesics.
    """
    if input == "-" and points == "-":
        raise InputFormatError("INPUT and POINTS cannot both be read from stdin (-)")
    ell, m = measure(distance, radius, ellipsoid)  # checked before the work
    d = (ell, distance if ell is None else m, radius)  # as given: the index converts it
    check_output(output)  # fail before the work
    tester: PerFeature | Union
    if each:
        feats = features(load(input, layer=layer, where=where, densify=densify))
        tester = PerFeature(feats, d, level)
    else:
        tester = Union(read(input, layer=layer, where=where, densify=densify), d, level)
    where = "<stdin>" if points == "-" else points  # from here on, the name of POINTS
    if points == "-":
        src = io.TextIOWrapper(sys.stdin.buffer, encoding="utf-8-sig", newline="")
        size = None
    else:
        try:
            src = open(points, encoding="utf-8-sig", newline="")  # a BOM is skipped
        except OSError as exc:
            raise InputFormatError(f"cannot read {points!r}: {exc.strerror}") from None
        size = os.fstat(src.fileno()).st_size
    try:
        with open_output(output, text=True) as dst:
            _run(tester, src, dst, where, size, chunk)
    finally:
        src.close()


def _run(tester, src, dst, where, size, chunk):
    reader = csv.reader(src)
    try:
        header = next(reader)
    except StopIteration:
        raise InputFormatError(f"{where}: empty file, expected a header with lon and lat") from None
    except (csv.Error, UnicodeDecodeError) as exc:
        raise InputFormatError(f"{where}, line 1: {exc}") from None
    ilon = _column(header, LON_NAMES, where)
    ilat = _column(header, LAT_NAMES, where)
    lowered = [h.strip().lower() for h in header]
    iout = lowered.index("inside") if "inside" in lowered else None
    writer = csv.writer(dst, lineterminator="\n")
    bar = progress_bar(total=size, unit="B", unit_scale=True)
    started = False
    done = 0
    try:
        batches = _chunks(reader, chunk)
        while True:
            try:
                rows, lines = next(batches)
            except StopIteration:
                if not started:  # no rows: the header alone
                    writer.writerow(tester.header(header, iout))
                break
            except (csv.Error, UnicodeDecodeError) as exc:
                raise InputFormatError(f"{where}, line {reader.line_num}: {exc}") from None
            lon, lat = _coordinates(rows, lines, len(header), ilon, ilat, where)
            if not started:  # the first batch is good: start the output
                writer.writerow(tester.header(header, iout))
                # bins as deep as the expected number of points makes worthwhile
                expect = len(rows)
                read_so_far = _position(src)
                if size and read_so_far:
                    expect = max(expect, int(size / read_so_far * len(rows)))
                tester.start(expect)
                started = True
            writer.writerows(tester.rows(rows, lon, lat, iout))
            done += len(rows)
            if bar is not None:
                bar.update(((_position(src) or 0) if size else done) - bar.n)
    finally:
        if bar is not None:
            bar.close()
    return done


def _flagged(rows, inside, iout):
    """The rows with their 'inside' column (added at the end, or set where it was)."""
    flag = np.where(inside, "true", "false").tolist()
    if iout is None:
        return [r + [f] for r, f in zip(rows, flag)]
    for r, f in zip(rows, flag):
        r[iout] = f
    return rows


def _tester(shape, d, level, expect):
    """``inside(lon, lat)`` for the batches, ``d`` being ``(None, distance as given,
    radius)``: the spherical index, or ``(ellipsoid, metres, radius)``: the ellipsoidal
    contains."""
    ell, distance, radius = d
    if ell is not None:

        def on_ellipsoid(lon, lat):
            return ellipsoidal_contains(
                shape, lon, lat, distance=distance, level=level, ellipsoid=ell
            )

        return on_ellipsoid
    return Index(shape, distance, radius=radius, level=level, depth=depth_for(expect)).contains


class Union:
    """Points tested against the region of the whole input (the default)."""

    def __init__(self, shape, d, level):
        self.shape, self.d, self.level = shape, d, level
        self.index: Callable | None = None

    def header(self, header, iout):
        return header if iout is not None else [*header, "inside"]

    def start(self, expect):
        self.index = _tester(self.shape, self.d, self.level, expect)

    def rows(self, rows, lon, lat, iout):
        assert self.index is not None  # after start
        return _flagged(rows, self.index(lon, lat), iout)


class PerFeature:
    """Points tested against each feature alone (``--each``): a row per point and feature
    it lies in, with the feature's index and properties; a row with 'inside' false for a
    point in none."""

    def __init__(self, feats, d, level):
        self.d, self.level = d, level
        self.rows_of = [i for i, f in enumerate(feats) if isinstance(f, dict) and f.get("geometry")]
        self.shapes = [
            read({"type": "FeatureCollection", "features": [feats[i]]}) for i in self.rows_of
        ]
        props = [dict(feats[i].get("properties") or {}) for i in self.rows_of]
        self.names = list(dict.fromkeys(k for p in props for k in p))
        self.values = [
            ["" if p.get(k) is None else str(p.get(k)) for k in self.names] for p in props
        ]
        self.indexes = []

    def header(self, header, iout):
        base = header if iout is not None else [*header, "inside"]
        return [*base, "feature", *self.names]

    def start(self, expect):
        self.indexes = [_tester(s, self.d, self.level, expect) for s in self.shapes]

    def rows(self, rows, lon, lat, iout):
        hits = np.array([inside(lon, lat) for inside in self.indexes]).reshape(
            len(self.indexes), len(rows)
        )
        out = []
        blank = [""] * (1 + len(self.names))
        for r, row in enumerate(_flagged(rows, hits.any(axis=0), iout)):
            found = np.flatnonzero(hits[:, r])
            if len(found) == 0:
                out.append(row + blank)
            for k in found.tolist():
                out.append(row + [str(self.rows_of[k]), *self.values[k]])
        return out
