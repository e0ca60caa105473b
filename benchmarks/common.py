"""Shared helpers of the benchmark scripts: timing, seeded inputs and the JSON record."""

from __future__ import annotations

import json
import os
import platform
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "data"
RESULTS = Path(__file__).resolve().parent / "results"


def best_of(fn, repeat: int = 3) -> tuple[float, object]:
    """Smallest wall time of ``repeat`` calls, and the last result."""
    best, out = float("inf"), None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def points_around(bounds, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``n`` points uniform in lon/lat inside ``bounds`` (W, S, E, N), seeded."""
    rng = np.random.default_rng(seed)
    w, s, e, nn = bounds
    return rng.uniform(w, e, n), rng.uniform(s, nn, n)


def write(name: str, record: dict) -> Path:
    """Write ``record`` with machine details to ``benchmarks/results/NAME.json``."""
    RESULTS.mkdir(exist_ok=True)
    record = {
        "machine": {
            "cpu_count": os.cpu_count(),
            "platform": platform.platform(),
            "python": platform.python_version(),
            "numpy": np.__version__,
        },
        **record,
    }
    path = RESULTS / f"{name}.json"
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(record, indent=2))
    tmp.replace(path)
    return path


def coastline(n: int = 70_000, seed: int = 0, center=(20.0, 10.0), radius_deg: float = 10.0):
    """A star-shaped ring of n vertices whose radius has a 1/f spectrum (seeded)."""
    import gloffset

    rng = np.random.default_rng(seed)
    spec = np.zeros(n // 2 + 1, dtype=complex)
    f = np.arange(1, len(spec))
    spec[1:] = 0.25 / f * np.exp(1j * rng.uniform(0.0, 2.0 * np.pi, len(f))) * (f < 3000)
    r = np.maximum(1.0 + np.fft.irfft(spec, n) * n / 2, 0.2) * radius_deg
    th = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    lat = center[1] + r * np.sin(th)
    lon = center[0] + r * np.cos(th) / np.cos(np.radians(center[1]))
    return gloffset.Shape.from_lonlat(lon, lat, closed=True)


def in_box(feature, box) -> bool:
    """Whether the mean of a GeoJSON feature's exterior vertices lies in ``box`` (W, S, E, N)."""
    g = feature["geometry"]
    polys = g["coordinates"] if g["type"] == "MultiPolygon" else [g["coordinates"]]
    pts = np.concatenate([np.asarray(p[0]) for p in polys])
    lon, lat = pts.mean(axis=0)
    return box[0] <= lon <= box[2] and box[1] <= lat <= box[3]
