"""Vector tiles (MVT) of the offset region: gloffset against PostGIS, in one run.

What a map maker builds today is a PostGIS function source (behind Martin or
pg_tileserv) that answers each tile with

    ST_AsMVT(ST_AsMVTGeom(ST_Transform(ST_Buffer(geog, d)::geometry, 3857),
                          ST_TileEnvelope(z, x, y)))

For Mexico (data/mexico_10m.geojson) and a fjord coast (Greenland of
data/countries_10m.geojson: Norway is not in that file) this takes seeded random tiles
that the region's boundary crosses, zooms 4 to 11, each at a new distance (20-200 km;
nothing of an earlier distance can be reused), and times one tile of each tool:
``gloffset.vector_tile`` (the input's edges near the tile offset and resolved, or the
whole offset resolved where the tile reaches much of the input, then the tile cut) and
the PostGIS query above (timed inside the database by ``clock_timestamp()``). It reports
per-tile times (p50, p90), mean tile bytes and each tool's boundary error: the exact
distance (float64, :func:`gloffset.distance`) of every vertex of the tile that is not
on the buffered tile's edge, minus d. Then the z0-12 pyramid of Mexico at 127 km as MVT
(PMTiles) against the raster pyramid (256 px PNG, PMTiles).

Run: python benchmarks/mvt.py [--tiles 24] [--maxzoom 12] [--psql "psql -U postgres"]
PostGIS: Debian's postgresql-15-postgis-3 (``pg_ctlcluster 15 main start``); without
it (or without a running server) the PostGIS columns are skipped with a message. As
root, psql runs as the ``postgres`` user (``runuser -u postgres -- psql``).
Writes benchmarks/results/mvt.json.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shlex
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import mapbox_vector_tile
import mercantile
import numpy as np
from common import DATA, write

import gloffset
from gloffset.mvt import vector_tile
from gloffset.mvt.pyramid import mvt_pyramid

EXTENT, BUFFER = 4096, 64
DB = "gloffset_bench"


def inputs():
    fc = json.loads((DATA / "countries_10m.geojson").read_text())
    green = [f for f in fc["features"] if f["properties"]["name"] == "Greenland"]
    return {
        "mexico": json.loads((DATA / "mexico_10m.geojson").read_text()),
        "greenland": {"type": "FeatureCollection", "features": green},
    }


def frontier_tiles(shape, n: int, seed: int):
    """``n`` seeded (z, x, y, metres): zooms 4-11, tiles the boundary at that new
    distance crosses (a point of the exact offset lies in them)."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        d = float(rng.uniform(20e3, 200e3))
        z = int(rng.integers(4, 12))
        off = gloffset.offset(shape, d).resolve()
        pts = np.concatenate(off.sample(1e-4))
        p = pts[rng.integers(len(pts))]
        lon = math.degrees(math.atan2(p[1], p[0]))
        lat = math.degrees(math.asin(max(-1.0, min(1.0, p[2]))))
        if abs(lat) > 85:
            continue
        t = mercantile.tile(lon, lat, z)
        out.append((z, t.x, t.y, round(d, 1)))
    return out


def vertices(tile: bytes, z: int, x: int, y: int):
    """Lon/lat of the tile's polygon vertices off the buffered tile's edge."""
    dec = mapbox_vector_tile.decode(tile, default_options={"y_coord_down": True})
    pts = []
    for layer in dec.values():
        for f in layer["features"]:
            g = f["geometry"]
            polys = [g["coordinates"]] if g["type"] == "Polygon" else g["coordinates"]
            for poly in polys:
                for ring in poly:
                    pts.extend(ring)
    if not pts:
        return np.zeros(0), np.zeros(0)
    uv = np.asarray(pts, dtype=np.float64)
    n = 1 << z
    lo, hi = -BUFFER, EXTENT + BUFFER
    edge = np.any((uv <= lo + 1e-9) | (uv >= hi - 1e-9), axis=1)
    edge |= (uv[:, 1] + y * EXTENT <= 0) | (uv[:, 1] + y * EXTENT >= n * EXTENT)
    uv = uv[~edge]
    lon = (x + uv[:, 0] / EXTENT) / n * 360.0 - 180.0
    lat = np.degrees(np.arctan(np.sinh(np.pi * (1 - 2 * (y + uv[:, 1] / EXTENT) / n))))
    return lon, lat


def boundary_error_m(shape, tile, z, x, y, d):
    lon, lat = vertices(tile, z, x, y)
    if len(lon) == 0:
        return None
    dist = gloffset.distance(shape, lon, lat)
    return np.abs(dist - abs(d))


def psql_command(given: str | None):
    if given:
        return shlex.split(given)
    if shutil.which("psql") is None:
        return None
    if os.geteuid() == 0:
        return ["runuser", "-u", "postgres", "--", "psql"]
    return ["psql"]


def psql(cmd, sql: str, db: str | None = DB) -> str:
    args = [*cmd, "-X", "-q", "-At", "-v", "ON_ERROR_STOP=1"]
    if db:
        args += ["-d", db]
    run = subprocess.run(args, input=sql, capture_output=True, text=True, timeout=3600)
    if run.returncode != 0:
        raise RuntimeError(run.stderr.strip())
    return run.stdout


FUNCTION = """
CREATE OR REPLACE FUNCTION bench_tile(name text, z int, x int, y int, d float8,
    OUT ms float8, OUT tile bytea) AS $$
DECLARE t0 timestamptz;
BEGIN
  t0 := clock_timestamp();
  SELECT ST_AsMVT(q, name, 4096, 'geom') INTO tile FROM (
    SELECT ST_AsMVTGeom(ST_Transform(ST_Buffer(geog, d)::geometry, 3857),
                        ST_TileEnvelope(z, x, y), 4096, 64, true) AS geom
    FROM shapes WHERE shapes.name = bench_tile.name) q;
  ms := extract(epoch FROM clock_timestamp() - t0) * 1000;
END $$ LANGUAGE plpgsql;
"""


def postgis_setup(cmd, data: dict) -> str | None:
    """Create the database, load the inputs as geography; None when it works, else why not."""
    try:
        version = psql(cmd, "SELECT 1", db="postgres")
        del version
    except (RuntimeError, OSError) as exc:
        return f"no PostgreSQL server answers ({exc}); start it with pg_ctlcluster 15 main start"
    try:
        psql(cmd, f"DROP DATABASE IF EXISTS {DB}; CREATE DATABASE {DB};", db="postgres")
        psql(cmd, "CREATE EXTENSION postgis;")
    except RuntimeError as exc:
        return f"PostGIS is not installed ({exc}): apt-get install postgresql-15-postgis-3"
    rows = []
    for name, gj in data.items():
        geoms = [f["geometry"] for f in gj["features"]] if "features" in gj else [gj]
        for g in geoms:
            text = json.dumps(g).replace("'", "''")
            rows.append(f"('{name}', ST_GeomFromGeoJSON('{text}')::geography)")
    psql(
        cmd,
        "CREATE TABLE shapes (name text, geog geography);\n"
        + "INSERT INTO shapes VALUES "
        + ",\n".join(rows)
        + ";\n"
        + "CREATE TABLE merged AS SELECT name, ST_Union(geog::geometry)::geography AS geog "
        "FROM shapes GROUP BY name; DROP TABLE shapes; ALTER TABLE merged RENAME TO shapes;\n"
        + FUNCTION,
    )
    return None


def postgis_tile(cmd, name, z, x, y, d) -> tuple[float, bytes]:
    out = psql(
        cmd, f"SELECT ms, encode(tile, 'hex') FROM bench_tile('{name}', {z}, {x}, {y}, {d});"
    )
    ms, hexed = out.strip().split("|")
    return float(ms) / 1000.0, bytes.fromhex(hexed)


def summary(values):
    v = np.asarray(values, dtype=np.float64)
    return {"p50": float(np.median(v)), "p90": float(np.percentile(v, 90)), "mean": float(v.mean())}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--tiles", type=int, default=24)
    ap.add_argument("--maxzoom", type=int, default=12)
    ap.add_argument("--psql", default=None, help="the psql command (default: psql, as postgres)")
    ap.add_argument("--skip-pyramid", action="store_true")
    args = ap.parse_args()

    data = inputs()
    cmd = psql_command(args.psql)
    why = "psql is not installed" if cmd is None else postgis_setup(cmd, data)
    if why:
        print(f"PostGIS skipped: {why}")
    record: dict = {"tiles_per_input": args.tiles, "extent": EXTENT, "buffer": BUFFER}
    for name, gj in data.items():
        shape = gloffset.read(gj)
        tiles = frontier_tiles(shape, args.tiles, seed=1 if name == "mexico" else 2)
        g_t, g_b, g_err, p_t, p_b, p_err = [], [], [], [], [], []
        for z, x, y, d in tiles:
            dd = d + 0.1  # a distance no earlier call resolved (the sampling resolved d)
            t = time.perf_counter()
            tile = vector_tile(shape, dd, z, x, y)
            g_t.append(time.perf_counter() - t)
            g_b.append(len(tile))
            e = boundary_error_m(shape, tile, z, x, y, dd)
            if e is not None:
                g_err.append(float(e.max()))
            if not why:
                sec, ptile = postgis_tile(cmd, name, z, x, y, dd)
                p_t.append(sec)
                p_b.append(len(ptile))
                e = boundary_error_m(shape, ptile, z, x, y, dd)
                if e is not None:
                    p_err.append(float(e.max()))
        rec = {
            "tiles": tiles,
            "gloffset_s": summary(g_t),
            "gloffset_bytes_mean": float(np.mean(g_b)),
            "gloffset_error_m": summary(g_err) if g_err else None,
        }
        if not why:
            rec.update(
                postgis_s=summary(p_t),
                postgis_bytes_mean=float(np.mean(p_b)),
                postgis_error_m=summary(p_err) if p_err else None,
                speedup_p50=float(np.median(p_t) / np.median(g_t)),
            )
        record[name] = rec
        line = (
            f"{name}: gloffset p50 {1e3 * rec['gloffset_s']['p50']:.0f} ms "
            f"(p90 {1e3 * rec['gloffset_s']['p90']:.0f}), {rec['gloffset_bytes_mean']:.0f} B, "
            f"error max p50 {rec['gloffset_error_m']['p50'] if g_err else float('nan'):.2f} m"
        )
        if not why:
            perr = rec["postgis_error_m"]["p50"] / 1e3 if p_err else float("nan")
            line += (
                f"; PostGIS p50 {1e3 * rec['postgis_s']['p50']:.0f} ms "
                f"(p90 {1e3 * rec['postgis_s']['p90']:.0f}), {rec['postgis_bytes_mean']:.0f} B, "
                f"error max p50 {perr:.1f} km"
                f"; speed-up at p50 {rec['speedup_p50']:.1f}x"
            )
        print(line, flush=True)
    if not args.skip_pyramid:
        shape = gloffset.read(DATA / "mexico_10m.geojson")
        with tempfile.TemporaryDirectory() as tmp:
            t = time.perf_counter()
            st = mvt_pyramid(shape, "127km", (0, args.maxzoom), Path(tmp) / "v.pmtiles")
            t_mvt = time.perf_counter() - t
            size_mvt = (Path(tmp) / "v.pmtiles").stat().st_size
            shape = gloffset.read(DATA / "mexico_10m.geojson")
            t = time.perf_counter()
            gloffset.tiles.pyramid(shape, "127km", f"0-{args.maxzoom}", Path(tmp) / "r.pmtiles")
            t_png = time.perf_counter() - t
            size_png = (Path(tmp) / "r.pmtiles").stat().st_size
        record["pyramid"] = {
            "zooms": [0, args.maxzoom],
            "mvt_s": t_mvt,
            "mvt_frontier": st.frontier,
            "mvt_inside": st.inside,
            "mvt_bytes": size_mvt,
            "png_s": t_png,
            "png_bytes": size_png,
            "ratio": t_mvt / t_png,
        }
        print(
            f"pyramid z0-{args.maxzoom} of Mexico at 127 km: MVT {t_mvt:.1f} s "
            f"({st.frontier:,} frontier, {st.inside:,} inside tiles, {size_mvt / 1e6:.1f} MB), "
            f"PNG {t_png:.1f} s ({size_png / 1e6:.1f} MB): {t_mvt / t_png:.2f}x"
        )
    if why:
        record["postgis"] = f"skipped: {why}"
    print(write("mvt", record))


if __name__ == "__main__":
    main()
