"""Tile pyramid of Mexico (10m) at d = 0.02 rad, z0-z12: the hierarchical pyramid
(gloffset.tiles.pyramid) against rendering every tile of the bounding box tile by tile,
the same pyramid with an outline of the border against the plain fill, and a 6 x 2048
cube render, in one run.

Run: python benchmarks/tiles.py [--maxzoom 12] [--direct-maxzoom 5]
Writes benchmarks/results/tiles.json. Tile by tile renders every tile covering Mexico's
bounding box grown by d up to ``--direct-maxzoom``, and above it a seeded sample of 12
tiles per zoom, extrapolated by the zoom's tile count (the JSON says which is which).
The plain pyramid also records its progress events: the first estimate of the tile
count, and the ETA at a quarter, half and three quarters of the run against the time
it really took.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import mercantile
import numpy as np
from common import DATA, write

import gloffset
from gloffset.gl import context_info
from gloffset.grids import Cube, Tile

D = 0.02  # radians
OUTLINE = "#202020"


def progress_record(events):
    """The first estimate of the tile count, and the ETA at a quarter, half and three
    quarters of the run's time against the time that was really left."""
    end = events[-1].seconds
    at = {}
    for q in (0.25, 0.5, 0.75):
        e = min(events, key=lambda e: abs(e.seconds - q * end))
        at[str(q)] = {
            "seconds": e.seconds,
            "eta_s": e.eta,
            "left_s": end - e.seconds,
            "done": e.done,
            "total": e.total,
        }
    first_write = next(e for e in events if e.done > 0)
    return {
        "events": len(events),
        "first_total": events[0].total,
        "total_at_first_tile": first_write.total,
        "final_total": events[-1].total,
        "at_share_of_time": at,
    }


def grown_bbox(shape, d):
    """Mexico's lon/lat bounding box grown by d (degrees; no antimeridian here)."""
    lon, lat = gloffset.geometry.sphere.xyz_to_lonlat(shape.edges().a)
    pad = math.degrees(d)
    s, n = float(lat.min()) - pad, float(lat.max()) + pad
    grow = pad / math.cos(math.radians(max(abs(s), abs(n))))
    return float(lon.min()) - grow, s, float(lon.max()) + grow, n


def tile_by_tile(shape, bbox, zmax, full_up_to, sample=12, seed=0):
    """Seconds of rendering the bbox tiles of zooms 0..zmax alone, each through
    gloffset.raster.render: every tile up to ``full_up_to``, a seeded random sample of
    ``sample`` tiles above it (extrapolated to the zoom's tile count)."""
    rng = np.random.default_rng(seed)
    per_zoom = {}
    for z in range(zmax + 1):
        tiles = list(mercantile.tiles(*bbox, zooms=[z]))
        run = tiles
        if z > full_up_to and len(tiles) > sample:
            run = [tiles[i] for i in rng.choice(len(tiles), sample, replace=False)]
        t = time.perf_counter()
        for tl in run:
            gloffset.render(shape, D, Tile(z, tl.x, tl.y), radius=1.0)
        s = time.perf_counter() - t
        per_zoom[z] = {
            "tiles": len(tiles),
            "rendered": len(run),
            "s_measured": s,
            "s": s * len(tiles) / len(run),
            "extrapolated": len(run) < len(tiles),
        }
    return per_zoom


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--maxzoom", type=int, default=12)
    ap.add_argument("--direct-maxzoom", type=int, default=5)
    args = ap.parse_args()
    shape = gloffset.read(DATA / "mexico_10m.geojson")
    gloffset.render(shape, D, Tile(0, 0, 0), radius=1.0)  # warm the GL context up

    events = []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "mexico.mbtiles"
        t = time.perf_counter()
        st = gloffset.tiles.pyramid(
            shape, D, (0, args.maxzoom), out, radius=1.0, progress=events.append
        )
        pyramid_s = time.perf_counter() - t
        size_mb = out.stat().st_size / 1e6
        t = time.perf_counter()
        st_out = gloffset.tiles.pyramid(
            shape, D, (0, args.maxzoom), Path(tmp) / "outline.mbtiles", radius=1.0, outline=OUTLINE
        )
        outline_s = time.perf_counter() - t

    bbox = grown_bbox(shape, D)
    direct = tile_by_tile(shape, bbox, args.maxzoom, args.direct_maxzoom)
    all_tiles = {z: v["tiles"] for z, v in direct.items()}
    direct_total = sum(v["s"] for v in direct.values())
    per_tile = direct_total / sum(all_tiles.values())

    t = time.perf_counter()
    gloffset.render(shape, D, Cube(2048), radius=1.0)
    cube_s = time.perf_counter() - t

    record = {
        "device": context_info()["renderer"],
        "gl_version": context_info()["version"],
        "distance_rad": D,
        "zooms": [0, args.maxzoom],
        "tile_size": 256,
        "pyramid": {
            **{k: v for k, v in st.as_dict().items() if k != "zooms"},
            "total_s": pyramid_s,
            "rendered_tiles_per_s": st.rendered / pyramid_s,
            "written_tiles_per_s": st.written / pyramid_s,
            "mbtiles_mb": size_mb,
            "per_zoom": st.zooms,
        },
        "tile_by_tile": {
            "bbox_grown_by_d": bbox,
            "tiles_per_zoom": all_tiles,
            "tiles_total": sum(all_tiles.values()),
            "all_tiles_rendered_up_to_zoom": args.direct_maxzoom,
            "per_zoom": direct,
            "mean_s_per_tile": per_tile,
            "total_s": direct_total,
            "total_s_is": "measured up to all_tiles_rendered_up_to_zoom; above it a seeded "
            "random sample of 12 tiles per zoom, extrapolated by the zoom's tile count",
        },
        "speedup_pyramid_vs_tile_by_tile": direct_total / pyramid_s,
        "progress": progress_record(events),
        "pyramid_outline": {
            "outline": OUTLINE,
            **{k: v for k, v in st_out.as_dict().items() if k != "zooms"},
            "total_s": outline_s,
            "seconds_over_plain_fill": outline_s / pyramid_s,
        },
        "cube_6x2048_s": cube_s,
    }
    path = write("tiles", record)
    print(path)
    p = record["pyramid"]
    print(
        f"pyramid z0-{args.maxzoom}: {p['total_s']:.1f} s, {p['rendered']} rendered "
        f"({p['rendered_tiles_per_s']:.1f}/s, {p['render_calls']} calls), {p['inside']} inside, "
        f"{p['outside']} outside; tile by tile ~{direct_total:.0f} s "
        f"({per_tile:.3f} s/tile); speed-up {record['speedup_pyramid_vs_tile_by_tile']:.0f}x; "
        f"cube 6x2048 {cube_s:.2f} s"
    )
    o = record["pyramid_outline"]
    print(
        f"with --outline: {o['total_s']:.1f} s ({o['painted']} outlined without rendering), "
        f"{o['seconds_over_plain_fill']:.2f} x the plain fill"
    )
    for q, v in record["progress"]["at_share_of_time"].items():
        eta = "?" if v["eta_s"] is None else f"{v['eta_s']:.1f}"
        print(f"at {q} of the time: ETA {eta} s, really {v['left_s']:.1f} s left")


if __name__ == "__main__":
    main()
