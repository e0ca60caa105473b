"""Draw the README pictures from gloffset's own output (run: python docs/figures.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

import gloffset

HERE = Path(__file__).resolve().parent
DATA = HERE.parent / "data"


def vector_offsets(path=HERE / "mexico_offsets.png", size=(720, 460)):
    """Mexico (10m) and the regions within 50, 127 and 250 km of it (float64 reference
    at pixel centres), equirectangular."""
    w, s, e, n = -125.0, 5.0, -78.0, 38.0
    width, height = size
    shape = gloffset.read(DATA / "mexico_10m.geojson")
    lon = w + (np.arange(width) + 0.5) * (e - w) / width
    lat = n - (np.arange(height) + 0.5) * (n - s) / height
    lon, lat = np.meshgrid(lon, lat)
    inside = gloffset.contains(shape, lon, lat)
    dist = gloffset.distance(shape, lon, lat)
    rgb = np.full((height, width, 3), (250, 250, 248), dtype=np.uint8)
    for d, col in [(250e3, (209, 229, 240)), (127e3, (146, 197, 222)), (50e3, (67, 147, 195))]:
        rgb[dist <= d] = col
    rgb[inside] = (60, 60, 60)
    img = Image.fromarray(rgb)
    img.save(path)
    return path


if __name__ == "__main__":
    print(vector_offsets())
