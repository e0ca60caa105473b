"""One command for a GL device: the GL tests and bounded render, pyramid and field timings.

``python benchmarks/gpu.py [--skip-tests] [--budget SECONDS]``

On whatever device EGL gives (``GLOFFSET_DEVICE=N`` picks one: :mod:`gloffset.gl.context`),
it prints the device, then

1. runs the GL test modules (``tests/test_shaders.py``, ``test_render.py``,
   ``test_tiles.py``, ``test_field.py``, ``test_field_walk_gpu.py``) with pytest in a
   child process (on a hardware device with ``-m "not slow"``, so that the tests marked
   ``gpu`` run too; on llvmpipe
   the default selection), and records their counts and time;
2. times, in this process, each once after a warm-up (so the GL context and the
   compiled shaders are not counted):

   * renders at 127 km: Mexico (1:10m) and the 234 countries of 1:10m at 4096 x 2048;
   * a pyramid: Mexico at 127 km, zooms 0-8, 256-pixel tiles, MBTiles;
   * a signed distance field: the 1:10m countries at 1024 x 512 (``--field-size``);
   * five distances (10, 50, 127, 250, 500 km) at once against five single renders of
     Mexico at 4096 x 2048.

3. then the measures of issue 39 ("the GPU does the work"):

   * ``host_share``: :mod:`host_share`'s three workloads of the 234 countries (the render
     at 4096 x 2048, the distance field at 4096 x 2048, the z0-7 pyramid), each the best
     of two warm runs, with the time inside GL calls and the host's share;
   * ``tile_field``: :mod:`tile_field`'s 256 px tiles, one per zoom 3-10 (about a vertex
     of Mexico's boundary), on Mexico and on the countries: the field, the render and
     the floor (the field of one point), best of three.

Each timing is skipped (and says so) once ``--budget`` seconds have passed (default 420,
so that the run stays within 8 minutes on a hardware GPU; 1200 on llvmpipe).

Each output is recorded by its SHA-256 (each render's mask, the five masks, the pyramid's
tiles in order, the field's float32 values and its signs), so that two devices' runs say
whether they drew the same. On llvmpipe the record is ``benchmarks/results/gpu.json``, the
reference; on any other device ``gpu_device.json``, and the run then prints, per step, the
speed-up over the llvmpipe reference and whether each output is the same (masks and tiles
must be; the field's values may differ within its accuracy contract, which the GL tests of
step 1 check, its signs must not). Step 3's speed-ups are against llvmpipe's
``results/host_share.json`` and ``results/tile_field.json`` (the same workloads and
tiles). The other benchmarks' results are left alone.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from common import DATA, RESULTS, ROOT, write  # noqa: E402

import gloffset  # noqa: E402
from gloffset.gl.context import context_info  # noqa: E402
from gloffset.grids import Equirect  # noqa: E402

GL_TESTS = [
    "tests/test_shaders.py",
    "tests/test_render.py",
    "tests/test_tiles.py",
    "tests/test_field.py",
    "tests/test_field_walk_gpu.py",
    "tests/test_walk_check.py",
]
DISTANCE = 127e3
FIVE = [10e3, 50e3, 127e3, 250e3, 500e3]


def run_tests(software: bool, timeout: float) -> dict:
    """The GL test modules in a child process: its counts, exit status and time."""
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *GL_TESTS]
    if not software:
        cmd += ["-m", "not slow"]  # the gpu-marked tests too
    t = time.perf_counter()
    try:
        proc = subprocess.run(
            cmd, cwd=ROOT, capture_output=True, text=True, timeout=timeout, env=os.environ.copy()
        )
    except subprocess.TimeoutExpired:
        return {"command": " ".join(cmd[1:]), "timed_out_s": timeout}
    seconds = time.perf_counter() - t
    last = (proc.stdout.strip().splitlines() or [""])[-1]
    counts = {k: int(n) for n, k in re.findall(r"(\d+) (passed|failed|skipped|errors?)", last)}
    print(f"tests: {last} (exit {proc.returncode})", flush=True)
    if proc.returncode != 0:
        print(proc.stdout[-4000:], proc.stderr[-2000:], sep="\n", flush=True)
    return {"command": " ".join(cmd[1:]), "exit": proc.returncode, "s": seconds, **counts}


def sha(*arrays) -> str:
    """The SHA-256 (hex, 16 digits) of the arrays' bytes, in order."""
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


def tiles_sha(path: Path) -> str:
    """The SHA-256 of an MBTiles archive's tiles (zoom, column, row and bytes, in order)."""
    with sqlite3.connect(path) as db:
        rows = db.execute(
            "SELECT zoom_level, tile_column, tile_row, tile_data FROM tiles ORDER BY 1, 2, 3"
        ).fetchall()
    h = hashlib.sha256()
    for z, x, y, data in rows:
        h.update(f"{z}/{x}/{y}:".encode())
        h.update(data)
    return h.hexdigest()[:16]


def timed(fn) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def renders(mexico, world) -> dict:
    grid = Equirect(4096, 2048)
    out = {}
    for name, shape in (("mexico_10m", mexico), ("countries_10m", world)):
        gloffset.render(shape, DISTANCE, Equirect(512, 256))  # caches and shaders
        t = time.perf_counter()
        mask = gloffset.render(shape, DISTANCE, grid)
        s = time.perf_counter() - t
        out[name] = {"size": [4096, 2048], "distance_m": DISTANCE, "s": s, "sha": sha(mask)}
    return out


def pyramid(mexico) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "mexico.mbtiles"
        t = time.perf_counter()
        st = gloffset.tiles.pyramid(mexico, DISTANCE, "0-8", out)
        s = time.perf_counter() - t
        digest = tiles_sha(out)
    return {
        "sha": digest,
        "zooms": [0, 8],
        "tile_size": 256,
        "s": s,
        "written": st.written,
        "rendered": st.rendered,
    }


def field(world, size) -> dict:
    t = time.perf_counter()
    f = gloffset.distance_field(world, Equirect(*size))
    s = time.perf_counter() - t
    return {
        "input": "countries_10m",
        "size": list(size),
        "s": s,
        "min_m": float(f.values.min()),
        "sha": sha(f.values),
        "signs_sha": sha(np.sign(f.values).astype(np.int8)),
    }


def five_distances(mexico) -> dict:
    grid = Equirect(4096, 2048)
    single = timed(lambda: [gloffset.render(mexico, d, grid) for d in FIVE])
    t = time.perf_counter()
    masks = gloffset.render_many(mexico, FIVE, grid)
    many = time.perf_counter() - t
    return {
        "distances_m": FIVE,
        "single_s": single,
        "many_s": many,
        "ratio": many / single,
        "sha": sha(*masks),
    }


def host_share_step() -> dict:
    """Issue 39's three workloads (:func:`host_share.measure`: the countries' render, field
    and pyramid), the best of two warm runs each."""
    import host_share

    return host_share.measure(False, "countries", 2)


def tile_field_step(mexico, world) -> dict:
    """:func:`tile_field.measure_input` on one tile per zoom 3-10 of each input."""
    import tile_field

    points = tile_field.boundary_points(1)
    return {
        name: tile_field.measure_input(name, shape, points, 3)
        for name, shape in (("mexico_10m", mexico), ("countries_10m", world))
    }


def against_issue39(rec: dict) -> dict:
    """Step 3's speed-ups over llvmpipe's records of the same measures (``host_share``
    per workload, ``tile_field`` per tile: field and render), where those exist."""
    out: dict = {}
    path = RESULTS / "host_share.json"
    if path.exists() and isinstance(rec.get("host_share"), dict):
        ref = json.loads(path.read_text())
        for name, row in rec["host_share"].items():
            if isinstance(row, dict) and "wall_s" in row and "wall_s" in ref.get(name, {}):
                out[f"host_share {name}"] = {"speedup": ref[name]["wall_s"] / row["wall_s"]}
    path = RESULTS / "tile_field.json"
    if path.exists() and isinstance(rec.get("tile_field"), dict):
        ref = json.loads(path.read_text()).get("inputs", {})
        for name, got in rec["tile_field"].items():
            theirs = {tuple(r["tile"]): r for r in ref.get(name, {}).get("tiles", [])}
            for row in got.get("tiles", []):
                old = theirs.get(tuple(row["tile"]))
                if old is not None:
                    out[f"tile_field {name} {'/'.join(map(str, row['tile']))}"] = {
                        f"speedup_{k}": old[f"{k}_s"] / row[f"{k}_s"] for k in ("field", "render")
                    }
    return out


def against(rec: dict, ref: dict) -> dict:
    """Per step of ``rec`` (another device's run), the speed-up over the llvmpipe
    reference ``ref`` and whether each output's SHA-256 is the same (None where either
    run lacks it)."""
    out: dict = {}

    def one(name, a, b, seconds="s"):
        if not isinstance(a, dict) or not isinstance(b, dict) or seconds not in a:
            return
        row = {"speedup": b[seconds] / a[seconds] if seconds in b else None}
        for key in ("sha", "signs_sha"):
            if key in a or key in b:
                row[f"same_{key}"] = a[key] == b[key] if key in a and key in b else None
        out[name] = row

    for name in ("mexico_10m", "countries_10m"):
        one(f"render {name}", rec.get("render", {}).get(name), ref.get("render", {}).get(name))
    one("pyramid", rec.get("pyramid"), ref.get("pyramid"))
    one("field", rec.get("field"), ref.get("field"))
    one("five_distances", rec.get("five_distances"), ref.get("five_distances"), "many_s")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skip-tests", action="store_true")
    ap.add_argument(
        "--budget",
        type=float,
        default=None,
        help="seconds before timings stop (420; 1200 on llvmpipe)",
    )
    ap.add_argument("--test-timeout", type=float, default=600.0)
    ap.add_argument("--field-size", default="1024x512")
    args = ap.parse_args()
    t0 = time.perf_counter()
    info = context_info()
    device = {k: info[k] for k in ("device", "renderer", "vendor", "version", "software")}
    print(f"device: {device['renderer']} ({device['vendor']}, {device['version']})", flush=True)
    if args.budget is None:
        args.budget = 1200.0 if info["software"] else 420.0
    rec = {"device": device, "GLOFFSET_DEVICE": os.environ.get("GLOFFSET_DEVICE")}
    if not args.skip_tests:
        rec["tests"] = run_tests(info["software"], args.test_timeout)
    mexico = gloffset.read(DATA / "mexico_10m.geojson")
    world = gloffset.read(DATA / "countries_10m.geojson")
    size = tuple(int(v) for v in args.field_size.split("x"))
    steps = [
        ("render", lambda: renders(mexico, world)),
        ("pyramid", lambda: pyramid(mexico)),
        ("field", lambda: field(world, size)),
        ("five_distances", lambda: five_distances(mexico)),
        ("host_share", host_share_step),
        ("tile_field", lambda: tile_field_step(mexico, world)),
    ]
    for name, step in steps:
        if time.perf_counter() - t0 > args.budget:
            rec[name] = {"skipped": f"the budget of {args.budget:g} s was spent"}
        else:
            rec[name] = step()
        print(f"{name}: {rec[name]}", flush=True)
    rec["total_s"] = time.perf_counter() - t0
    reference = RESULTS / "gpu.json"
    if not info["software"] and reference.exists():
        rec["against_llvmpipe"] = against(rec, json.loads(reference.read_text()))
        rec["against_llvmpipe"] |= against_issue39(rec)
        for name, row in rec["against_llvmpipe"].items():
            print(f"against llvmpipe, {name}: {row}", flush=True)
    path = write("gpu" if info["software"] else "gpu_device", rec)
    print(f"total {rec['total_s']:.1f} s; wrote {path}")


if __name__ == "__main__":
    main()
