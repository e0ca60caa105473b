"""Tile pyramids: the tiles held are exactly those the reference puts pixels of the region
in; fully-inside tiles are all inside; resume; MBTiles and directory layouts; CLI."""

import functools
import hashlib
import io
import json
import math
import os
import pickle
import re
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import assert_options_refused, read_dir, read_mbtiles
from PIL import Image, ImageDraw

import gloffset
from gloffset.cli import main
from gloffset.edges import CurveArcs
from gloffset.errors import OptionError
from gloffset.geometry.sphere import angle, arc_distance, lonlat_to_xyz
from gloffset.grids import Tile
from gloffset.grids.mercator import TilePyramid
from gloffset.io.png import palette_png
from gloffset.reference import contains_xyz, distance_xyz
from gloffset.tiles.tiling import TilesError, parse_zooms, pyramid
from gloffset.tiles.tiling.tilepaint import TileStyle

SIZE = 64
EPS = 1e-3  # of a pixel, as in test_render
SQUARE = {
    "type": "Polygon",
    "coordinates": [
        [[-60, -50], [60, -50], [60, 50], [-60, 50], [-60, -50]],
        [[-10, -10], [-10, 10], [10, 10], [10, -10], [-10, -10]],
    ],
}
LINE_AM = {"type": "LineString", "coordinates": [[170, -10], [-170, 5], [-160, 40]]}


def alpha(png):
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"))[..., 3]


def pixel_centres(g):
    jj, ii = np.meshgrid(np.arange(g.height), np.arange(g.width), indexing="ij")
    return g.centers(g.n_levels - 1, jj.ravel(), ii.ravel())


def near_boundary(shape, p, d, eps):
    """Pixels within eps of the offset boundary or of a ring edge (where float32 may differ)."""
    near = np.abs(distance_xyz(shape, p) - abs(d)) <= eps
    arcs = CurveArcs.from_shape(shape)
    ring = arcs.group >= 0
    if ring.any():
        ring_d = arc_distance(p[:, None], arcs.a[ring][None], arcs.b[ring][None]).min(axis=1)
        near |= ring_d <= eps
    return near


def check_against_reference(shape, d, tiles, zmax, full_png):
    """Every tile of zooms 0..zmax: present iff the reference has a pixel centre of it in
    the region, its pixels equal the reference (up to EPS of a pixel), and tiles holding
    the shared full image are all inside."""
    shape = gloffset.read(shape)
    n_full = 0
    for z in range(zmax + 1):
        keys = [(x, y) for x in range(1 << z) for y in range(1 << z)]
        p = np.concatenate([pixel_centres(Tile(z, x, y, SIZE)) for x, y in keys])
        want_all = contains_xyz(shape, p, d).reshape(len(keys), -1)
        p = p.reshape(len(keys), -1, 3)
        for k, (x, y) in enumerate(keys):
            want = want_all[k]
            png = tiles.get((z, x, y))
            got = np.zeros(SIZE * SIZE, bool) if png is None else alpha(png).ravel() > 0
            bad = np.flatnonzero(got != want)
            if len(bad):
                eps = EPS * math.pi * 2 / ((1 << z) * SIZE)
                assert near_boundary(shape, p[k][bad], d, eps).all(), (z, x, y, len(bad))
            if png is not None:
                assert got.any(), f"empty tile {z}/{x}/{y} written"
            if png == full_png:
                n_full += 1
                assert want.all(), f"tile {z}/{x}/{y} written as inside is not all inside"
    return n_full


@pytest.fixture(scope="module")
def brazil(world):
    return world["Brazil"]


def test_parse_zooms():
    assert parse_zooms("3-7") == (3, 7) and parse_zooms(" 4 ") == (4, 4)
    for bad in ("7-3", "0-23", "a-b", "-1", "1-2-3", ""):
        with pytest.raises(TilesError, match="zoom"):
            parse_zooms(bad)


def test_tile_bounds_are_rigorous():
    lv = TilePyramid(12)
    rng = np.random.default_rng(1)
    for z in range(13):
        rows = np.arange(1 << z) if z <= 8 else rng.integers(0, 1 << z, 256)
        r = lv.decision_rho(z, rows)
        assert np.all(
            r <= lv.decision_rho(z, max(0, (1 << z) // 2 - 1)) * (1 + 1e-9)
        )  # r_eq is max
        # random points of the rectangles are within r of the centres
        y = rows + rng.uniform(0, 1, (64, len(rows)))
        lat = np.degrees(np.arctan(np.sinh(np.pi * (1 - 2 * y / (1 << z)))))
        lon = rng.uniform(-0.5, 0.5, y.shape) * 360.0 / (1 << z)
        c = lv.centers(z, rows, 0)
        c = c * 1.0
        lon_c = -180.0 + 180.0 / (1 << z)
        assert np.all(angle(c[None], lonlat_to_xyz(lon + lon_c, lat)) <= r[None])
        if z < 12:  # the list bound nests: L(parent) >= angle(parent, child) + L(child)
            for dy in (0, 1):
                for dx in (0, 1):
                    cc = lv.centers(z + 1, 2 * rows + dy, dx)
                    lhs = angle(c, cc) + lv.rho_at(z + 1, 2 * rows + dy, dx)
                    assert np.all(lv.rho_at(z, rows, 0) >= lhs)


@pytest.mark.parametrize(
    "name, d, zmax",
    [
        ("square", 300e3, 4),
        pytest.param("Brazil", -300e3, 4, marks=pytest.mark.slow),
        ("line", 300e3, 4),
    ],
)
def test_pyramid_holds_exactly_the_tiles_of_the_region(tmp_path, world, name, d, zmax):
    shape = {"line": LINE_AM, "square": SQUARE}.get(name) or world[name]
    st = pyramid(shape, d, (0, zmax), tmp_path / "t.mbtiles", size=SIZE)
    tiles, meta = read_mbtiles(tmp_path / "t.mbtiles")
    full = gloffset.tiles.tiling.tilepaint.TileStyle().encode(np.ones((SIZE, SIZE), bool))
    n_full = check_against_reference(shape, d / gloffset.EARTH_RADIUS, tiles, zmax, full)
    assert st.written == len(tiles) and n_full >= st.inside
    assert st.rendered > 0 and st.outside > 0
    if name == "square":
        assert st.inside > 0  # the shared-image path is exercised
        # one image blob serves every fully-inside tile
        db = sqlite3.connect(tmp_path / "t.mbtiles")
        tid = hashlib.md5(full).hexdigest()
        assert db.execute("SELECT count(*) FROM images WHERE tile_id=?", (tid,)).fetchone() == (1,)
        assert db.execute("SELECT count(*) FROM map WHERE tile_id=?", (tid,)).fetchone()[0] >= (
            st.inside
        )


def test_mbtiles_metadata_and_tms_rows(tmp_path, world):
    path = tmp_path / "mx.mbtiles"
    pyramid(world["Mexico"], "127km", "1-3", path, size=SIZE, name="Mexico", source="Mexico 110m")
    tiles, meta = read_mbtiles(path)
    assert meta["format"] == "png" and meta["type"] == "overlay" and meta["name"] == "Mexico"
    assert (meta["minzoom"], meta["maxzoom"]) == ("1", "3")
    assert meta["description"] == (
        "Region within 127km of Mexico 110m, polygons included "
        f"(127km = 127000 m = 0.019934 rad); gloffset {gloffset.__version__}"
    )
    assert meta["version"]
    w, s, e, n = (float(v) for v in meta["bounds"].split(","))
    assert (w, s, e, n) == pytest.approx((-135, 0, -45, 40.979898), abs=1e-6)  # z3 edges
    # Mexico lies in XYZ 1/0/0 (north-west), stored as TMS row 1
    db = sqlite3.connect(path)
    rows = db.execute("SELECT tile_column, tile_row FROM map WHERE zoom_level=1").fetchall()
    assert rows == [(0, 1)]
    assert set(tiles) >= {(1, 0, 0)} and min(z for z, _, _ in tiles) == 1


def test_description_names_the_input_and_the_distance(tmp_path, mexico_path):
    """The description metadata: the distance as given, its metres and radians (on the
    sphere used), and the input's file stem (the output's name stands in for nothing)."""
    rad = 60e3 / gloffset.EARTH_RADIUS
    out = tmp_path / "shrunk.mbtiles"
    pyramid(mexico_path, -60e3, "0-1", out, size=16)
    desc = read_mbtiles(out)[1]["description"]
    assert desc.startswith(
        "Points of mexico_10m inside its polygons and farther than 60000 m from their "
        f"boundary (-60000 m = -{rad:.6g} rad); gloffset "
    ), desc
    out = tmp_path / "moon.mbtiles"
    pyramid(str(mexico_path), "100 km", "0-1", out, size=16, radius=1737.4e3)
    desc = read_mbtiles(out)[1]["description"]
    assert desc.startswith(
        "Region within 100 km of mexico_10m, polygons included (100 km = 100000 m = "
        f"{100e3 / 1737.4e3:.6g} rad on a sphere of radius 1737400 m); gloffset "
    ), desc
    pyramid({"type": "Point", "coordinates": [0, 0]}, "0.02rad", "0", tmp_path / "d", size=16)
    meta = json.loads((tmp_path / "d" / "metadata.json").read_text())
    assert meta["description"].startswith(
        "Region within 0.02rad of the input, polygons included (0.02rad = 127420.176 m = 0.02 rad)"
    )


def test_directory_output_with_links_and_outline(tmp_path):
    out = tmp_path / "dir"
    st = pyramid(SQUARE, 1500e3, "0-4", out, size=SIZE, outline="#ff0000", outline_width=2)
    files = read_dir(out)
    assert len(files) == st.written and st.painted > 0
    meta = json.loads((out / "metadata.json").read_text())
    assert meta["maxzoom"] == 4 and "bounds" in meta
    # outline pixels (opaque red) on the tiles the border crosses
    red = 0
    for png in files.values():
        rgba = np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"))
        red += int(((rgba[..., 0] == 255) & (rgba[..., 1] == 0) & (rgba[..., 3] == 255)).sum())
    assert red > 100
    # without outline the fully-inside tiles are hard links of one file
    plain = tmp_path / "plain"
    st = pyramid(SQUARE, 300e3, "0-4", plain, size=SIZE)
    links = [p for p in plain.rglob("*.png") if p.stat().st_nlink > 1]
    assert st.inside > 1 and len(links) == st.inside


def _outline_per_arc(arcs, which, center, r, z, x, y, size):
    """The outline's points arc by arc with scalar maths (as drawn before OutlineArcs)."""
    from gloffset.geometry.sphere import xyz_to_lonlat

    out = []
    world = float((1 << z) * size)
    lon_c = float(xyz_to_lonlat(center)[0])
    lat_c = math.asin(max(-1.0, min(1.0, float(center[2]))))
    step = 0.5 * 2.0 * math.pi * max(math.cos(lat_c), 1e-3) / world
    for k in which:
        a, n = arcs.a[k], arcs.n[k]
        if not np.any(n):
            continue
        w = np.cross(n, a)
        theta = math.atan2(float(np.linalg.norm(np.cross(a, arcs.b[k]))), float(a @ arcs.b[k]))
        ca, cw = float(center @ a), float(center @ w)
        rho = math.hypot(ca, cw)
        if rho <= 0.0 or math.cos(r) > rho:
            continue
        t0 = math.atan2(cw, ca)
        half = math.acos(max(-1.0, min(1.0, math.cos(r) / rho))) + r
        lo, hi = max(0.0, t0 - half), min(theta, t0 + half)
        if lo > hi:
            continue
        t = np.linspace(lo, hi, max(2, int(math.ceil((hi - lo) / step)) + 1))
        p = np.cos(t)[:, None] * a + np.sin(t)[:, None] * w
        lon, lat = xyz_to_lonlat(p)
        lon = lon_c + (np.asarray(lon) - lon_c + 180.0) % 360.0 - 180.0
        lat = np.clip(np.radians(lat), -math.radians(89.0), math.radians(89.0))
        px = ((lon + 180.0) / 360.0) * world - x * size - 0.5
        py = (0.5 - np.arcsinh(np.tan(lat)) / (2.0 * math.pi)) * world - y * size - 0.5
        out.append(np.column_stack([px, py]).ravel().tolist())
    return out


@pytest.mark.parametrize(
    "name, tiles",
    [
        ("Mexico", [(0, 0, 0), (1, 0, 0), (3, 1, 3), (5, 7, 14), (6, 14, 27), (8, 57, 110)]),
        ("Fiji", [(2, 3, 2), (2, 0, 2), (4, 15, 8), (6, 63, 35)]),
        ("line", [(0, 0, 0), (2, 3, 1), (2, 0, 1), (3, 7, 3)]),
    ],
)
def test_outline_points_are_those_of_the_arc_by_arc_maths(world, name, tiles):
    """OutlineArcs.lines (numpy over a tile's arcs, scalar maths only near the disc's
    edge) gives the floats of the arc-by-arc maths to within a few ulps (numpy's SIMD
    loops may round the last bit differently from the scalar maths, by CPU), so the
    drawn pixels are the same; on tiles where the disc's edge cuts arcs, at zoom 0 (disc
    wider than a hemisphere) and across the antimeridian."""
    from gloffset.tiles.tiling.tilepaint import OutlineArcs

    arcs = CurveArcs.from_shape(gloffset.read(LINE_AM if name == "line" else world[name]))
    prepared = OutlineArcs(arcs)
    which = np.flatnonzero(arcs.boundary)
    levels = TilePyramid(12)
    cut = 0
    for z, x, y in tiles:
        c = levels.centers(z, y, x)
        for scale in (1.0, 0.5, 0.1):  # the tile's bound and smaller discs
            r = float(levels.decision_rho(z, y)) * scale
            want = _outline_per_arc(arcs, which, c, r, z, x, y, 256)
            got = prepared.lines(which, c, r, z, x, y, 256)
            assert [len(line) for line in got] == [len(line) for line in want], (z, x, y)
            for g, w in zip(got, want):
                np.testing.assert_allclose(g, w, rtol=1e-14, atol=1e-9, err_msg=str((z, x, y)))
            cut += len(want)
    assert cut >= 2 * len(tiles)


def test_outline_across_the_antimeridian(tmp_path):
    out = tmp_path / "am"
    pyramid(LINE_AM, 100e3, "2", out, size=SIZE, outline="#000000", fill="#ffffff", opacity=0.0)
    files = read_dir(out)
    # only the outline shows, on both sides of 180 deg
    assert {x for _, x, _ in files} == {0, 3}


class Stop(Exception):
    pass


@pytest.mark.parametrize("colors", [1, 2, 3, 4])
@pytest.mark.parametrize("shape", [(1, 1), (5, 7), (3, 13), (64, 64), (256, 256)])
def test_palette_png_decodes_to_its_index_and_colours(colors, shape):
    rng = np.random.default_rng(colors * 1000 + shape[1])
    index = rng.integers(0, colors, size=shape).astype(np.uint8)
    palette = [tuple(int(v) for v in rng.integers(0, 256, 4)) for _ in range(colors)]
    img = Image.open(io.BytesIO(palette_png(index, palette)))
    img.load()
    assert img.mode == "P" and img.size == (shape[1], shape[0])
    assert np.array_equal(np.asarray(img), index)  # rows padded to whole bytes, high bits first
    lut = np.array(palette, dtype=np.uint8)
    assert np.array_equal(np.asarray(img.convert("RGBA")), lut[index])
    with pytest.raises(ValueError, match="1 to 4 colours"):
        palette_png(index, palette * 5)


@pytest.mark.parametrize("outline", [None, "#202020"])
def test_tile_png_shows_the_mask_and_outline_pillow_draws(outline):
    """Tiles are encoded by ``palette_png`` (1 bit a pixel, 2 with outline pixels): they
    decode to the colours of the mask, with the outline Pillow draws on top."""
    style = TileStyle("#3070c0", 0.5, outline, 3)
    yy, xx = np.mgrid[:SIZE, :SIZE]
    mask = (xx - 20) ** 2 + (yy - 30) ** 2 < 400
    lines = [np.array([[0.5, 3.0], [40.2, 60.7], [63.0, 10.0]]), [10.0, 10.0, 50.0, 12.0]]
    img = Image.fromarray(mask.astype(np.uint8), mode="P")
    if outline is not None:
        draw = ImageDraw.Draw(img)
        for pts in lines:
            draw.line(np.ravel(pts).tolist(), fill=2, width=3)
    want = np.array(style.palette(), dtype=np.uint8)[np.asarray(img)]
    png = style.encode(mask, lines)
    got = Image.open(io.BytesIO(png))
    assert got.info["transparency"][0] == 0  # outside is transparent
    assert np.array_equal(np.asarray(got.convert("RGBA")), want)
    assert (outline is not None) == (np.asarray(got).max() == 2)
    assert style.encode(np.zeros((SIZE, SIZE), bool)) is None
    if outline is not None:  # an outline alone shows
        assert style.encode(np.zeros((SIZE, SIZE), bool), lines) is not None
        assert style.encode(np.zeros((SIZE, SIZE), bool), [[-9.0, -9.0, -5.0, -5.0]]) is None


@pytest.mark.parametrize(
    "name, d, zooms, kw",
    [
        ("square", 300e3, "0-6", dict(size=64)),  # bin levels 2 zooms ahead
        ("square", 300e3, "2-7", dict(size=16)),  # no bin levels: the growth alone
        ("Mexico", 127e3, "0-8", dict(size=256)),  # 4 zooms ahead
        ("line", 300e3, "1-7", dict(size=32)),
        ("Brazil", -300e3, "0-7", dict(size=32, outline="#000000")),
        ("Mexico", 50e3, "6", dict(size=64)),  # one zoom
    ],
)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_progress_events(tmp_path, world, mexico_path, name, d, zooms, kw):
    """The total is known before the first tile, never below the tiles done, and equal
    to them at the last event only; before three quarters of the tiles are done the
    bar shows at most 90 %; the share of the time reaches exactly 1 at the end only."""
    shape = {"line": LINE_AM, "square": SQUARE, "Mexico": mexico_path}.get(name) or world[name]
    events = []
    st = pyramid(shape, d, zooms, tmp_path / "t.mbtiles", progress=events.append, **kw)
    first, last = events[0], events[-1]
    assert isinstance(first, gloffset.tiles.tiling.TileProgress)
    assert first.done == 0 and first.total > 0 and first.eta is None
    assert last.done == last.total and last.eta == 0.0 and last.fraction == 1.0
    # every tile handled is counted: written, rendered empty (or outlined with nothing)
    assert st.written + st.empty <= last.done
    if "outline" not in kw:
        assert last.done == st.written + st.empty == st.rendered + st.inside
    done = [e.done for e in events]
    assert done == sorted(done) and [e.zoom for e in events] == sorted(e.zoom for e in events)
    assert all(e.total >= e.done for e in events)
    assert all(e.done < e.total and e.fraction < 1.0 for e in events[:-1])
    assert all(e.eta is None or e.eta >= 0.0 for e in events)
    assert any(e.eta is not None and e.eta > 0.0 for e in events)  # an ETA before the end
    # not at (or near) 100 % before the last quarter of the work
    assert max(e.done / e.total for e in events if e.done < 0.75 * last.done) < 0.9
    # refined as it goes: exact once the bin levels below the frontier reach max zoom
    zmin, zmax = gloffset.tiles.parse_zooms(zooms)
    ahead = max(0, kw["size"].bit_length() - 1 - 4)
    if "outline" not in kw:
        assert all(e.total == last.total for e in events if e.zoom >= max(zmax - ahead, zmin - 1))


@pytest.mark.parametrize("suffix", [".mbtiles", ""])
def test_interrupted_pyramid_resumes_to_the_same_tiles(tmp_path, suffix):
    kw = dict(size=SIZE, outline="#202020", name="square")
    whole = tmp_path / ("whole" + suffix)
    events = []
    full = pyramid(SQUARE, 1500e3, "0-4", whole, progress=events.append, **kw)
    assert full.rendered and full.inside and full.painted
    part = tmp_path / ("part" + suffix)

    def stop_after(p):
        if p.done >= full.written // 2:
            raise Stop

    with pytest.raises(Stop):
        pyramid(SQUARE, 1500e3, "0-4", part, progress=stop_after, **kw)
    read = read_mbtiles if suffix else read_dir

    def tiles(p):
        t = read(p)
        return t[0] if suffix else t

    got = tiles(part)
    assert 0 < len(got) < len(tiles(whole))  # a valid, partial output
    with pytest.raises(gloffset.GloffsetError, match="exists"):
        pyramid(SQUARE, 1500e3, "0-4", part, **kw)
    with pytest.raises(TilesError, match="other options"):
        pyramid(SQUARE, 300e3, "0-4", part, resume=True, **kw)
    resumed = []
    st = pyramid(SQUARE, 1500e3, "0-4", part, resume=True, progress=resumed.append, **kw)
    assert st.present > 0
    # the tiles already there count as handled: the resumed run ends where the whole did
    assert resumed[-1].done == resumed[-1].total == events[-1].done
    assert tiles(part) == tiles(whole)
    if suffix:
        assert read_mbtiles(part)[1] == read_mbtiles(whole)[1]


def test_cli_tiles_and_errors(tmp_path, world):
    src = tmp_path / "mx.geojson"
    src.write_text(json.dumps(world["Mexico"]))
    run = CliRunner().invoke
    out = str(tmp_path / "t.mbtiles")
    args = ["tiles", str(src), "-d", "200km", "-o", out, "--tile-size", "64"]
    style = ["--fill", "#3070c0", "--opacity", "0.6"]
    r = run(main, args + ["--zoom", "0-3"] + style)
    assert r.exit_code == 0, r.output
    assert "tiles written" in r.output
    tiles, meta = read_mbtiles(out)
    assert tiles and all(alpha(p).max() == 153 for p in tiles.values())
    # the input's name and the distance as given, in metres and radians (not the output's
    # name and the angle taken for kilometres)
    assert meta["name"] == "t" and meta["description"].startswith(
        f"Region within 200km of mx, polygons included (200km = 200000 m = "
        f"{200e3 / gloffset.EARTH_RADIUS:.6g} rad); gloffset"
    ), meta["description"]
    for extra, msg in [
        (["--zoom", "0-3"], "exists; use --resume"),
        (["--zoom", "0-23", "--force"], "MAX <= 22"),
        (["--zoom", "3-x", "--force"], "bad zoom range"),
        (["--zoom", "0-3", "--force", "--tile-size", "8"], "tile size"),
        (["--zoom", "0-3", "--force", "--tile-size", "300"], "power of two"),
        (["--zoom", "0-3", "--force", "--opacity", "2"], "opacity"),
        (["--zoom", "0-3", "--force", "--fill", "nocolour"], "colour"),
    ]:
        r = run(main, args + extra)
        assert r.exit_code == 2, (extra, r.output)
        assert msg in r.output and r.output.startswith("gloffset: error:"), r.output
    r = run(main, args + ["--zoom", "0-3", "--resume"])
    assert r.exit_code == 2 and "other options" in r.output
    r = run(main, args + ["--zoom", "0-3", "--resume"] + style)
    assert r.exit_code == 0 and "already present" in r.output


@pytest.mark.parametrize(
    "zmax, coords, d",
    [
        (16, [[10.30, 60.20], [10.31, 60.205], [10.32, 60.20]], 100.0),
        (19, [[-70.0001, -33.0], [-70.0, -33.0001], [-69.9999, -33.0]], 10.0),
        (22, [[179.99999, 0.0], [-179.99999, 0.00001]], 1.0),  # across the antimeridian
    ],
)
def test_deep_zoom_pyramid_matches_reference(tmp_path, zmax, coords, d):
    """Frontier tiles rendered in atlases from the pyramid's own frontier (not through
    gloffset.raster.render) agree with the float64 reference at deep zooms."""
    import mercantile

    line = {"type": "LineString", "coordinates": coords}
    pyramid(line, d, (zmax, zmax), tmp_path / "deep", size=SIZE)
    tiles = read_dir(tmp_path / "deep")
    assert tiles and all(z == zmax for z, _, _ in tiles)
    shape = gloffset.read(line)
    da = d / gloffset.EARTH_RADIUS
    pad = math.degrees(2 * da)
    lon = [c[0] for c in coords]
    lat = [c[1] for c in coords]
    boxes = [(min(lat) - pad, max(lat) + pad)]
    if max(lon) - min(lon) > 180:  # across the antimeridian: two boxes
        west = [v for v in lon if v < 0]
        east = [v for v in lon if v > 0]
        lons = [(min(east) - pad, 180.0), (-180.0, max(west) + pad)]
    else:
        lons = [(min(lon) - pad, max(lon) + pad)]
    keys = {
        (t.x, t.y)
        for w, e in lons
        for s, n in boxes
        for t in mercantile.tiles(w, s, e, n, zooms=[zmax])
    }
    assert {(x, y) for _, x, y in tiles} <= keys
    eps = EPS * math.pi * 2 / ((1 << zmax) * SIZE)
    n_in = 0
    for x, y in sorted(keys):
        p = pixel_centres(Tile(zmax, x, y, SIZE))
        want = contains_xyz(shape, p, da)
        png = tiles.get((zmax, x, y))
        got = np.zeros(SIZE * SIZE, bool) if png is None else alpha(png).ravel() > 0
        bad = np.flatnonzero(got != want)
        assert near_boundary(shape, p[bad], da, eps).all(), (x, y, len(bad))
        n_in += int(got.sum())
    assert n_in > 100  # the region is resolved by many pixels


@pytest.mark.parametrize("size", [16, 512])
def test_pyramid_tiles_equal_render_for_other_tile_sizes(tmp_path, size):
    """Tiles of 16 pixels (a tile is one bin, no float64 level below it) and of 512
    equal gloffset.raster.render on the same Tile grid."""
    pyramid(SQUARE, 300e3, (0, 3), tmp_path / "o", size=size)
    tiles = read_dir(tmp_path / "o")
    assert len(tiles) > 10
    for (z, x, y), png in tiles.items():
        want = gloffset.render(SQUARE, 300e3, Tile(z, x, y, size)) > 0
        assert np.array_equal(alpha(png) > 0, want), (z, x, y)


def test_pmtiles_archive_holds_the_mbtiles_tiles_and_resumes(tmp_path):
    """A PMTiles archive reads back (the pmtiles reader) tile by tile equal to the MBTiles
    of the same pyramid, with the header's type, zooms, bounds and centre right and each
    distinct image stored once; an interrupted run resumes to the identical archive."""
    pytest.importorskip("pmtiles")
    from pmtiles.reader import MmapSource, Reader
    from pmtiles.tile import TileType

    from gloffset.tiles.store.pmtiles import read_pmtiles

    kw = dict(size=SIZE, outline="#202020", name="square")
    pyramid(SQUARE, 1500e3, "0-4", tmp_path / "a.mbtiles", **kw)
    whole = tmp_path / "a.pmtiles"
    events = []
    full = pyramid(SQUARE, 1500e3, "0-4", whole, progress=events.append, **kw)
    tiles_mb, meta_mb = read_mbtiles(tmp_path / "a.mbtiles")
    meta, tiles = read_pmtiles(whole)
    assert tiles == tiles_mb and len(tiles) == full.written
    assert meta["gloffset"] == meta_mb["gloffset"] and meta["format"] == "png"
    with open(whole, "rb") as f:
        header = Reader(MmapSource(f)).header()
    assert header["tile_type"] == TileType.PNG
    assert (header["min_zoom"], header["max_zoom"]) == (0, 4)
    assert header["addressed_tiles_count"] == len(tiles)
    assert header["tile_contents_count"] == len(set(tiles.values())) < len(tiles)
    w, s, e, n = (float(v) for v in meta_mb["bounds"].split(","))
    got = [header[k] / 1e7 for k in ("min_lon_e7", "min_lat_e7", "max_lon_e7", "max_lat_e7")]
    assert got[0] <= w and got[1] <= s and got[2] >= e and got[3] >= n
    assert np.allclose(got, [w, s, e, n], atol=2e-7)
    lon, lat, cz = (float(v) for v in meta_mb["center"].split(","))
    assert header["center_zoom"] == int(cz)
    assert abs(header["center_lon_e7"] / 1e7 - lon) < 1e-7

    # interrupted: no archive yet, the staged tiles wait beside it; resume finishes it
    part = tmp_path / "b.pmtiles"

    def stop_after(p):
        if p.done >= full.written // 2:
            raise Stop

    with pytest.raises(Stop):
        pyramid(SQUARE, 1500e3, "0-4", part, progress=stop_after, **kw)
    assert not part.exists() and (tmp_path / "b.pmtiles.partial.mbtiles").exists()
    with pytest.raises(gloffset.GloffsetError, match="exists"):
        pyramid(SQUARE, 1500e3, "0-4", part, **kw)
    st = pyramid(SQUARE, 1500e3, "0-4", part, resume=True, **kw)
    assert st.present > 0
    assert part.read_bytes() == whole.read_bytes()
    assert not (tmp_path / "b.pmtiles.partial.mbtiles").exists()
    # resuming a finished archive changes nothing
    pyramid(SQUARE, 1500e3, "0-4", part, resume=True, **kw)
    assert part.read_bytes() == whole.read_bytes()
    # the command line writes it too
    out = tmp_path / "c.pmtiles"
    src = tmp_path / "sq.geojson"
    src.write_text(json.dumps(SQUARE))
    r = CliRunner().invoke(
        main, ["tiles", str(src), "-d", "1500km", "-z", "0-2", "-o", str(out), "--tile-size", "64"]
    )
    assert r.exit_code == 0, r.output
    pyramid(SQUARE, 1500e3, "0-2", tmp_path / "c.mbtiles", size=SIZE)
    assert read_pmtiles(out)[1] == read_mbtiles(tmp_path / "c.mbtiles")[0]


def test_an_empty_pyramid_is_a_valid_archive_in_every_format(tmp_path):
    """An inward offset that empties the shape covers no tile: MBTiles and PMTiles both
    hold no tile and the same metadata (PMTiles crashed in pmtiles' finalize_header)."""
    from gloffset.tiles.store.pmtiles import read_pmtiles

    small = {"type": "Polygon", "coordinates": [[[6, 49.5], [6.4, 49.5], [6.4, 49.9], [6, 49.5]]]}
    stats = pyramid(small, -50e3, "0-4", tmp_path / "e.pmtiles", size=SIZE)
    assert stats.written == 0
    meta, tiles = read_pmtiles(tmp_path / "e.pmtiles")
    assert tiles == {}
    pyramid(small, -50e3, "0-4", tmp_path / "e.mbtiles", size=SIZE)
    mb_tiles, mb_meta = read_mbtiles(tmp_path / "e.mbtiles")
    assert mb_tiles == {}
    assert meta["bounds"] == mb_meta["bounds"] and meta["minzoom"] == mb_meta["minzoom"]


@pytest.mark.slow  # starts a Dask cluster of two worker processes (about 20 s)
def test_pyramid_on_two_dask_workers_is_byte_identical(tmp_path):
    """A pyramid made by two worker processes (a LocalCluster) equals, byte for byte, the
    one made in one process, in MBTiles and PMTiles, with an outline (tiles kept for it
    cross the split); interrupted while the workers run, it resumes to the same."""
    pytest.importorskip("distributed")
    pytest.importorskip("pmtiles")
    from gloffset.tiles.store.pmtiles import read_pmtiles

    kw = dict(size=SIZE, outline="#202020", name="square")
    one = pyramid(SQUARE, 1500e3, "0-6", tmp_path / "one.mbtiles", **kw)
    two = pyramid(SQUARE, 1500e3, "0-6", tmp_path / "two.mbtiles", workers=2, **kw)
    assert read_mbtiles(tmp_path / "one.mbtiles") == read_mbtiles(tmp_path / "two.mbtiles")
    assert two.written == one.written and two.rendered == one.rendered
    pyramid(SQUARE, 1500e3, "0-6", tmp_path / "one.pmtiles", **kw)
    pyramid(SQUARE, 1500e3, "0-6", tmp_path / "two.pmtiles", workers=2, **kw)
    assert (tmp_path / "one.pmtiles").read_bytes() == (tmp_path / "two.pmtiles").read_bytes()
    assert read_pmtiles(tmp_path / "two.pmtiles")[1] == read_mbtiles(tmp_path / "one.mbtiles")[0]

    part = tmp_path / "part.mbtiles"

    def stop_late(p):
        if p.done >= one.written * 3 // 4:
            raise Stop

    with pytest.raises(Stop):
        pyramid(SQUARE, 1500e3, "0-6", part, workers=2, progress=stop_late, **kw)
    assert 0 < len(read_mbtiles(part)[0]) < one.written
    pyramid(SQUARE, 1500e3, "0-6", part, resume=True, workers=2, **kw)
    assert read_mbtiles(part) == read_mbtiles(tmp_path / "one.mbtiles")


class _Done:
    def __init__(self, value):
        self.value = value

    def result(self):
        return self.value


class _SyncClient:
    """A Dask client that runs each task at once, in this process and thread."""

    def scatter(self, x, broadcast=False):
        return x

    def run(self, fn, wait=True):
        __import__("asyncio").run(fn())

    def submit(self, fn, *args, pure=True):
        return _Done(fn(*args))

    def close(self):
        pass


@pytest.mark.parametrize(
    "name, d, zooms, workers, kw",
    [
        ("Mexico", 127e3, "0-6", 1, {}),  # frontier tiles of z0-1 as tasks of one tile
        pytest.param("Mexico", 127e3, "0-6", 4, {}, marks=pytest.mark.slow),  # a deeper split
        ("Mexico", -60e3, "3-6", 1, {}),  # the split below zoom min
        ("Mexico", 127e3, "0-1", 2, {}),  # the split at the deepest zoom
        ("square", 1500e3, "0-5", 2, {"outline": "#202020"}),  # outlined tiles
        pytest.param("neighbours", 60e3, "0-6", 2, {}, marks=pytest.mark.slow),  # shared borders
    ],
)
def test_split_pyramid_tasks_make_the_same_tiles(
    tmp_path, mexico_path, monkeypatch, name, d, zooms, workers, kw
):
    """A pyramid split into tasks (the frontier tiles above the split one by one, the
    kept tiles of the split zoom with their subtrees; run here one after the other by a
    client in this process) writes the tiles, the counts and the metadata of a run in
    one process; the shape sent to the tasks carries nothing derived from it."""
    pytest.importorskip("distributed")
    import distributed

    from gloffset.tiles.tiling import distributed as dist
    from gloffset.tiles.tiling import driver as tl

    def source():
        if name == "neighbours":  # nine countries of countries_10m that share borders
            fc = json.loads((mexico_path.parent / "countries_10m.geojson").read_text())
            names = {"France", "Spain", "Portugal", "Andorra", "Germany", "Belgium"}
            names |= {"Luxembourg", "Netherlands", "Austria"}
            feats = [f for f in fc["features"] if f["properties"].get("name") in names]
            assert len(feats) == len(names)
            return {"type": "FeatureCollection", "features": feats}
        return mexico_path if name == "Mexico" else SQUARE

    shape = gloffset.read(source())
    sizes = []
    subpyramid = tl.subpyramid

    def task(job, *args):
        sizes.append(len(pickle.dumps(job)))
        return subpyramid(pickle.loads(pickle.dumps(job)), *args)

    (tmp_path / "one").mkdir()
    (tmp_path / "two").mkdir()
    one = pyramid(shape, d, zooms, tmp_path / "one" / "t.mbtiles", size=SIZE, **kw)
    monkeypatch.setattr(dist, "_client", lambda workers, scheduler: (_SyncClient(), None))
    monkeypatch.setattr(distributed, "as_completed", iter)
    monkeypatch.setattr(tl, "subpyramid", task)
    events = []
    run_split = functools.partial(
        pyramid,
        shape,
        d,
        zooms,
        tmp_path / "two" / "t.mbtiles",
        size=SIZE,
        workers=workers,
        progress=events.append,
        **kw,
    )
    split = run_split()
    assert read_mbtiles(tmp_path / "one" / "t.mbtiles") == read_mbtiles(
        tmp_path / "two" / "t.mbtiles"
    )
    same = {"seconds": 0, "render_calls": 0}  # batches differ
    assert split.as_dict() | same == one.as_dict() | same
    # the progress covers the tasks: every tile counted once, the total reached at the end
    # only, an ETA from the tasks' pace
    first, last = events[0], events[-1]
    assert first.done == 0 and last.done == last.total and last.eta == 0.0
    if "outline" not in kw:
        assert last.done == split.written + split.empty == split.rendered + split.inside
    done = [e.done for e in events]
    assert done == sorted(done) and all(e.done < e.total for e in events[:-1])
    assert any(e.eta is not None and e.eta > 0.0 for e in events)
    fresh = gloffset.read(source())
    assert sizes and max(sizes) < 4 * len(pickle.dumps(fresh))  # its edges, no caches
    # resumed on the whole output: every task finds its tiles there, and the progress
    # counts them as done, as a run in one process does
    events.clear()
    again = run_split(resume=True)
    # (empty tiles are not stored: they are rendered again)
    assert again.present == one.written and again.rendered == one.empty
    assert events[-1].done == events[-1].total == last.done


def test_a_resumed_split_hands_each_task_the_tiles_it_has():
    """A task skips the tiles of a resumed output that are its tile or below it, down to
    its last zoom: a sub-pyramid's, or its one tile's."""
    from gloffset.tiles.tiling.distributed import _have_of

    have = {(2, 1, 1), (3, 2, 2), (3, 3, 3), (4, 4, 4), (3, 0, 0), (2, 0, 0), (5, 9, 9)}
    tasks = [((2, 1, 1), 255, None, 4), ((2, 0, 0), 255, None, 2), ((1, 0, 0), 255, None, 1)]
    tasks.append(((2, 1, 1), 255, None, 3))
    assert _have_of(have, tasks) == [
        {(2, 1, 1), (3, 2, 2), (3, 3, 3), (4, 4, 4)},
        {(2, 0, 0)},
        set(),
        {(2, 1, 1), (3, 2, 2), (3, 3, 3)},
    ]


@pytest.mark.parametrize("d", [100e3, -100e3])
def test_vertex_at_a_tile_corner(d, tmp_path):
    """A vertex at (0, 0), the centre of tile 0/0/0 and a corner of every tile around it,
    with an edge along the equator: a child's status is its parent's toggled by the
    crossings of child -> parent, which are not exact when the parent's centre lies on
    an edge (the whole northern hemisphere used to be written inside at 100 km)."""
    tri = {"type": "Polygon", "coordinates": [[[0, 0], [10, 0], [5, 8], [0, 0]]]}
    pyramid(tri, d, "0-4", tmp_path / "t", size=SIZE)
    tiles = read_dir(tmp_path / "t")
    assert len(tiles) >= 5
    for (z, x, y), png in tiles.items():
        want = gloffset.render(tri, d, Tile(z, x, y, SIZE)) > 0
        np.testing.assert_array_equal(alpha(png) > 0, want, err_msg=f"tile {z}/{x}/{y}")


def test_each_level_is_refined_once(tmp_path, mexico_path, monkeypatch):
    """The bin levels run ahead of the zoom walk and the walk reaches the same frontier
    later: each level is classified once (CurveCells.remember), with the tiles of a run
    that classifies it twice."""
    from gloffset.raster.vector import curves, node_levels

    calls = []

    def counting(orig):
        def refine(f, *args, **kw):
            calls.append((f.level, f.cells.tobytes()))
            return orig(f, *args, **kw)

        return refine

    # the levels of original arcs and those of the multiresolution curve (the coarse ones)
    monkeypatch.setattr(curves, "refine", counting(curves.refine))
    monkeypatch.setattr(node_levels, "refine", counting(node_levels.refine))
    mexico = gloffset.read(mexico_path)
    a = pyramid(mexico, 100e3, "0-6", str(tmp_path / "a.mbtiles"))
    assert calls and len(calls) == len(set(calls)), "a level was classified twice"
    monkeypatch.setattr(curves.CurveCells, "remember", lambda self, ahead: None)
    calls.clear()
    b = pyramid(mexico, 100e3, "0-6", str(tmp_path / "b.mbtiles"))
    assert len(calls) > len(set(calls))  # without it, the walk does the chain's work again

    def tiles(path):
        with sqlite3.connect(path) as con:
            return sorted(con.execute("SELECT * FROM tiles"))

    assert a.written == b.written and tiles(tmp_path / "a.mbtiles") == tiles(tmp_path / "b.mbtiles")


def _cli(*args, **env):
    proc = subprocess.run(
        [sys.executable, "-m", "gloffset", *map(str, args)],
        capture_output=True,
        text=True,
        env={**os.environ, **env},
    )
    assert proc.returncode == 0, proc.stderr
    return proc.stderr


@pytest.mark.slow  # 2.5 s; run by .ci/run with -m slow
def test_the_summary_counts_the_tiles_the_progress_counts(tmp_path, mexico_path):
    """Mexico z0-6: the progress ends at the tiles handled, which the summary names and
    splits into written, rendered empty (not written) and already present, fresh and
    resumed."""
    out = tmp_path / "mx.mbtiles"
    for flags in ([], ["--resume"]):
        err = _cli(
            "tiles",
            mexico_path,
            "-d",
            "400km",
            "-z",
            "0-6",
            "-o",
            out,
            *flags,
            GLOFFSET_PROGRESS="1",
        )
        bars = re.findall(r"z6, ([\d,]+)/([\d,]+) tiles", err)
        assert bars and bars[-1][0] == bars[-1][1], err
        total = int(bars[-1][1].replace(",", ""))
        m = re.search(
            r"([\d,]+) tiles handled: ([\d,]+) tiles written .*, ([\d,]+) rendered "
            r"empty and not written, ([\d,]+) already present",
            err,
        )
        assert m, err
        handled, written, empty, present = (int(g.replace(",", "")) for g in m.groups())
        assert handled == total == written + empty + present
        assert empty > 0 and (present > 0) == bool(flags)
    stats = pyramid(gloffset.read(mexico_path), "400km", (0, 6), tmp_path / "p")
    assert stats.handled == total and stats.as_dict()["handled"] == total


def test_an_unknown_option_is_refused_naming_the_documented_ones(tmp_path, world):
    """``pyramid(**options)`` refuses a misspelt option before any work, listing every
    option its docstring documents; ``pyramids`` takes the same options."""
    out = tmp_path / "mx.mbtiles"
    mexico = world["Mexico"]
    assert_options_refused(
        lambda: pyramid(mexico, "127km", "0-2", out, sise=64), pyramid, "pyramid"
    )
    assert_options_refused(
        lambda: gloffset.tiles.pyramids(mexico, ["10km"], "0-2", [out], sise=64),
        pyramid,
        "pyramids",
    )
    assert not out.exists()
    with pytest.raises(OptionError, match="opacity"):  # the style checked with the options
        pyramid(mexico, "127km", "0-2", out, opacity=2.0)
    gloffset.tiles.pyramids(mexico, ["10km"], "0-2", [out], size=64, outline="#ff0000")
    tiles, meta = read_mbtiles(out)
    red = [t for t, png in tiles.items() if (255, 0, 0, 255) in rgba_colours(png)]
    assert meta["name"] == "mx" and len(red) >= 3  # the outline, one tile a zoom at least


def rgba_colours(png: bytes) -> set:
    """The colours of a tile."""
    return {c for _, c in Image.open(io.BytesIO(png)).convert("RGBA").getcolors(1 << 16)}


def test_field_tiles_report_their_progress_as_the_raster_pyramids_do(tmp_path):
    """``tiles --field`` draws the raster pyramids' bar (zoom, tiles, time so far and
    left) on stderr where progress is shown (GLOFFSET_PROGRESS=1, as on a terminal),
    rising to every tile of the zooms; nothing otherwise; the tiles are the same."""
    world = Path(__file__).resolve().parents[1] / "data" / "world_110m.geojson"
    # Mexico at 1:110m: its fields are cheap on the CPU
    args = ("tiles", world, "--where", "NAME = 'Mexico'", "--field", "-z", "0-2")
    args += ("--tile-size", "32")
    quiet = CliRunner().invoke(main, [*map(str, args), "-o", str(tmp_path / "quiet")])
    assert quiet.exit_code == 0 and quiet.stderr.startswith("21 field tiles written"), quiet.stderr
    shown = CliRunner().invoke(
        main, [*map(str, args), "-o", str(tmp_path / "shown")], env={"GLOFFSET_PROGRESS": "1"}
    )
    err = shown.stderr
    assert shown.exit_code == 0, err
    bar = r"(\d+)%\|[^|]*\| z(\d+), ([\d,]+)/~?([\d,]+) tiles \[[\d:]+<([\d:?]+)\]"
    bars = re.findall(bar, err)
    assert bars[0][1:4] == ("0", "0", "21") and bars[0][4] == "?", err  # before the first tile
    assert bars[-1] == ("100", "2", "21", "21", "00:00"), err
    seen = [(int(z), int(done)) for _, z, done, _, _ in bars]
    # the bar is redrawn at most every 0.1 s: the first and last zooms are always drawn, a
    # zoom in between only if its tiles took that long
    assert seen == sorted(seen) and {0, 2} <= {z for z, _ in seen} <= {0, 1, 2}, err
    assert "21 field tiles written" in err
    for z, x, y in ((0, 0, 0), (2, 0, 1), (2, 3, 3)):
        one = tmp_path / "quiet" / str(z) / str(x) / f"{y}.png"
        assert one.read_bytes() == (tmp_path / "shown" / str(z) / str(x) / f"{y}.png").read_bytes()


def test_batches_cut_to_the_records_buffer_give_the_same_tiles(tmp_path, monkeypatch):
    """A batch of frontier tiles is cut where its frontier bins' pairs would overflow the
    one storage buffer of the records made on the GL context
    (:meth:`~gloffset.tiles.tiling.walk.BinChain.batches`): with a buffer of a few
    thousand records, the runs are many more, each within the buffer or of one tile,
    they cover every tile once and in order, and the tiles are those of the uncut
    pyramid, byte for byte (Mexico, real borders)."""
    from gloffset.gl.vector_pass import vector_passes
    from gloffset.tiles.tiling import walk

    shape = gloffset.read(Path(__file__).resolve().parents[1] / "data" / "mexico_10m.geojson")
    d = 0.01 * gloffset.EARTH_RADIUS
    whole = pyramid(shape, d, "3-6", tmp_path / "whole.mbtiles")
    runs = []
    cut = walk.BinChain.batches

    def batches(self, which, per_run, most):
        made = list(cut(self, which, per_run, most))
        assert np.array_equal(np.concatenate(made), which)  # every tile once, in order
        for b in made:
            assert len(b) <= per_run
            runs.append((len(b), len(self.layout(b, 4)[2].pair_cell), most))
        yield from made

    monkeypatch.setattr(walk.BinChain, "batches", batches)
    monkeypatch.setattr(vector_passes(), "max_records", 4000)
    small = pyramid(shape, d, "3-6", tmp_path / "small.mbtiles")
    assert small.render_calls > whole.render_calls
    assert all(n <= most or k == 1 for k, n, most in runs)
    assert any(k == 1 and n > most for k, n, most in runs)  # a tile alone over it
    assert any(k > 1 for k, n, most in runs)
    assert (
        read_mbtiles(tmp_path / "small.mbtiles")[0] == read_mbtiles(tmp_path / "whole.mbtiles")[0]
    )


def test_palette_png_bytes_are_those_of_the_chunks_written_out():
    # the chunks kept for a size and a palette give the bytes of writing them all anew
    import struct
    import zlib

    def chunk(kind, data):
        crc = struct.pack(">I", zlib.crc32(kind + data))
        return struct.pack(">I", len(data)) + kind + data + crc

    rng = np.random.default_rng(4)
    for n, (h, w) in ((2, (256, 256)), (3, (17, 33)), (1, (5, 9)), (4, (256, 256)), (2, (5, 9))):
        palette = [tuple(int(c) for c in rng.integers(0, 256, 4)) for _ in range(n)]
        index = rng.integers(0, n, (h, w))
        depth = 1 if n <= 2 else 2
        bits = np.unpackbits(index.astype(np.uint8)[..., None], axis=-1)[..., 8 - depth :]
        rows = np.concatenate(
            [np.zeros((h, 1), np.uint8), np.packbits(bits.reshape(h, -1), axis=1)], 1
        )
        want = b"".join(
            (
                b"\x89PNG\r\n\x1a\n",
                chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, 3, 0, 0, 0)),
                chunk(b"PLTE", bytes(c for rgba in palette for c in rgba[:3])),
                chunk(b"tRNS", bytes(rgba[3] for rgba in palette)),
                chunk(b"IDAT", zlib.compress(rows.tobytes(), 6)),
                chunk(b"IEND", b""),
            )
        )
        assert palette_png(index, palette) == want
        assert palette_png(index, [list(c) for c in palette]) == want  # lists as well
