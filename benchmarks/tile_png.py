"""Tile PNG encoding: gloffset's palette writer against Pillow's, on real tiles.

The masks are the rendered (frontier) tiles of a pyramid: Mexico 10m at d = 0.02 rad,
zooms 0-10, 256 px, read back from its MBTiles. Each mask is encoded by
``TileStyle.encode`` (:func:`gloffset.io.png.palette_png`: 1 bit a pixel, rows unfiltered,
zlib level 6) and by Pillow's PNG writer as tiles were written before (a palette image
with a transparency chunk: Pillow picks 2 bits a pixel for a 3-colour palette and filters
the rows), with and without ``optimize``. Per writer: microseconds per tile (best of 3),
mean bytes, and whether every tile decodes to the same RGBA as the mask's colours.

Run: python benchmarks/tile_png.py [--maxzoom 10]
Writes benchmarks/results/tile_png.json.
"""

from __future__ import annotations

import argparse
import io
import sqlite3
import tempfile
import time
from pathlib import Path

import numpy as np
from common import DATA, write
from PIL import Image

import gloffset
from gloffset.tiles.tiling.tilepaint import TileStyle

D = 0.02  # radians


def pillow(style: TileStyle, optimize: bool):
    pal = style.palette()

    def encode(mask: np.ndarray) -> bytes:
        img = Image.fromarray(mask.astype(np.uint8), mode="P")
        img.putpalette([c for rgba in pal for c in rgba[:3]])
        buf = io.BytesIO()
        img.save(buf, format="PNG", transparency=bytes(a[3] for a in pal), optimize=optimize)
        return buf.getvalue()

    return encode


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--maxzoom", type=int, default=10)
    args = ap.parse_args(argv)
    shape = gloffset.read(DATA / "mexico_10m.geojson")
    path = Path(tempfile.mkdtemp()) / "t.mbtiles"
    gloffset.tiles.pyramid(shape, D * gloffset.EARTH_RADIUS, f"0-{args.maxzoom}", path)
    db = sqlite3.connect(path)
    masks = []
    for (data,) in db.execute("SELECT tile_data FROM images"):
        m = np.asarray(Image.open(io.BytesIO(data))) > 0
        if 0 < m.sum() < m.size:  # rendered tiles: inside and outside pixels
            masks.append(m)
    db.close()
    style = TileStyle()
    lut = np.array(style.palette(), dtype=np.uint8)
    writers = {
        "gloffset_palette_png": style.encode,
        "pillow": pillow(style, False),
        "pillow_optimize": pillow(style, True),
    }
    out = {"input": "mexico_10m", "zooms": f"0-{args.maxzoom}", "tiles": len(masks), "writers": {}}
    for name, encode in writers.items():
        best = float("inf")
        for _ in range(3):
            t0 = time.perf_counter()
            blobs = [encode(m) for m in masks]
            best = min(best, time.perf_counter() - t0)
        same = all(
            np.array_equal(
                np.asarray(Image.open(io.BytesIO(b)).convert("RGBA")), lut[m.view(np.uint8)]
            )
            for b, m in zip(blobs, masks)
        )
        out["writers"][name] = {
            "us_per_tile": 1e6 * best / len(masks),
            "mean_bytes": float(np.mean([len(b) for b in blobs])),
            "decodes_to_the_mask": same,
        }
        print(f"{name:22s} {out['writers'][name]}", flush=True)
    print(f"wrote {write('tile_png', out)}")


if __name__ == "__main__":
    main()
