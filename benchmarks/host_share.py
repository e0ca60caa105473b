"""How much of a render's time the GL calls take, and how much is the host's alone.

gloffset draws with fragment shaders, but a run also spends time on the host: the
float64 scatter into the bin level, the arc records, a field's float64 walk down to
8 x 8 cells, the planning of the lists, the inside test. A
faster GPU only shortens the GL part. Per workload this prints the wall time (warm, no
profiler), the time inside moderngl's calls (draws, uploads, read-backs, object
creation), the host share ``1 - gl / wall`` and the host time, wall times that share:
what no GPU can speed up.

Method: every public method of moderngl's ``Context``, ``Program``, ``Buffer``,
``Texture``, ``TextureCube``, ``Framebuffer``, ``Renderbuffer``, ``VertexArray`` and
``ComputeShader`` is
wrapped, on the class, with a ``perf_counter`` pair (a call made inside another wrapped
call is counted once, in the outer one). The wrapper costs about a microsecond a call;
a run makes a few thousand GL calls, so the overhead is milliseconds. With Mesa's
llvmpipe a draw returns once queued and the read-back waits for it, so the draws' time
lands in the read-backs: the sum is still the GL time. GL time is summed over all
threads (the tile pyramid renders on one GL thread); the host time is the wall time
less that sum.

The wall time is the best of ``--repeat`` warm runs without the timers. One more run,
with them, gives the GL time and its own wall time: the host share is ``1 - gl / wall``
of that run (on a loaded machine two runs differ more than the GL part of one), and the
host time is the best wall time times that share.

``--walk gpu`` (or ``cpu``) makes a field's lists with the GPU walk (or the float64 host
walk). By default (``gloffset.raster.fields.gpu.WALK = "auto"``) a hardware GL walks on
the GPU, and so does llvmpipe where the lists' level has at least
``SOFTWARE_CELLS`` cells (the 4096 x 2048 field here); a tile's field walks on the host.

Run: python benchmarks/host_share.py [--quick] [-k NAME] [--walk auto|cpu|gpu]
Writes benchmarks/results/host_share.json (host_share_walk_WALK.json for another walk).
"""

from __future__ import annotations

import argparse
import functools
import tempfile
import threading
import time
from pathlib import Path

from common import DATA, best_of, write

import gloffset
from gloffset.grids import Equirect
from gloffset.raster.fields import gpu as field_gpu

D = 0.02  # radians on the unit sphere, as in render.py
R = gloffset.EARTH_RADIUS


class GLTimer:
    """Seconds spent inside moderngl's calls, summed over threads, while enabled."""

    CLASSES = (
        "Context",
        "Program",
        "Buffer",
        "Texture",
        "TextureCube",
        "Framebuffer",
        "Renderbuffer",
        "VertexArray",
        "ComputeShader",
    )

    def __init__(self):
        self.seconds = 0.0
        self.calls = 0
        self.enabled = False
        self._local = threading.local()
        self._lock = threading.Lock()
        self._installed = False

    def install(self):
        if self._installed:
            return
        import moderngl

        for cname in self.CLASSES:
            cls = getattr(moderngl, cname, None)
            if cls is None:
                continue
            for name, fn in list(vars(cls).items()):
                if name.startswith("_") or not callable(fn) or isinstance(fn, (type,)):
                    continue
                if isinstance(fn, (staticmethod, classmethod)):
                    continue
                setattr(cls, name, self._wrap(fn))
        self._installed = True

    def _wrap(self, fn):
        timer = self

        @functools.wraps(fn)
        def timed(*args, **kwargs):
            if not timer.enabled or getattr(timer._local, "depth", 0):
                return fn(*args, **kwargs)
            timer._local.depth = 1
            t = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                dt = time.perf_counter() - t
                timer._local.depth = 0
                with timer._lock:
                    timer.seconds += dt
                    timer.calls += 1

        return timed

    def measure(self, fn) -> tuple[float, float, int]:
        """Wall time, GL time and GL calls of one call of ``fn``."""
        self.seconds, self.calls, self.enabled = 0.0, 0, True
        try:
            t = time.perf_counter()
            fn()
            wall = time.perf_counter() - t
        finally:
            self.enabled = False
        return wall, self.seconds, self.calls


def workloads(quick: bool, tmp: Path, pick: str):
    """name -> thunk, for the names that contain ``pick``; the shapes are read once,
    outside the timing (and only those that a picked workload needs)."""
    w, h = (1024, 512) if quick else (4096, 2048)
    zmax = 4 if quick else 7
    grid = Equirect(w, h)
    n = iter(range(1_000_000))
    shapes: dict = {}

    def shape(name):
        if name not in shapes:
            shapes[name] = gloffset.read(DATA / f"{name}.geojson")
        return shapes[name]

    def tiles():
        out = tmp / f"t{next(n)}.mbtiles"
        gloffset.tiles.pyramid(shape("countries_10m"), D * R, f"0-{zmax}", out, overwrite=True)

    table = {
        f"render mexico {w}x{h}": lambda: gloffset.render(shape("mexico_10m"), D * R, grid),
        f"render countries {w}x{h}": lambda: gloffset.render(shape("countries_10m"), D * R, grid),
        f"distance_field countries {w}x{h}": (
            lambda: gloffset.distance_field(shape("countries_10m"), grid)
        ),
        f"tiles countries z0-{zmax}": tiles,
    }
    return {k: v for k, v in table.items() if pick in k}


def measure(quick: bool, pick: str, repeat: int) -> dict:
    """Per workload of :func:`workloads` (``quick``, ``pick``): its best wall time of
    ``repeat`` warm runs, and one more run's GL time, GL calls and host share; printed."""
    timer = GLTimer()
    timer.install()
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, fn in workloads(quick, Path(tmp), pick).items():
            fn()  # warm: the shape's caches, the GL context, the shaders
            wall, _ = best_of(fn, repeat)
            timed, gl, calls = timer.measure(fn)
            share = max(1.0 - gl / timed, 0.0)
            rows[name] = {
                "wall_s": wall,
                "timed_wall_s": timed,
                "gl_s": gl,
                "gl_calls": calls,
                "host_share": share,
                "host_s": wall * share,
            }
            print(
                f"{name:34s} wall {wall:7.3f} s  GL {gl:7.3f} s of {timed:7.3f} s "
                f"({calls} calls)  host share {share:.0%}  host {wall * share:7.3f} s",
                flush=True,
            )
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="1024x512 images, tiles z0-4")
    ap.add_argument("-k", default="", help="only the workloads whose name contains this")
    ap.add_argument("--repeat", type=int, default=3, help="warm runs, the best kept")
    ap.add_argument(
        "--walk",
        choices=("auto", "cpu", "gpu"),
        default="auto",
        help="the field's walk (gloffset.raster.fields.gpu.WALK; gpu: a hardware GL's)",
    )
    args = ap.parse_args(argv)
    field_gpu.WALK = args.walk
    rows = measure(args.quick, args.k, args.repeat)
    write(
        "host_share" if args.walk == "auto" else f"host_share_walk_{args.walk}",
        {
            "distance_rad": D,
            "quick": args.quick,
            "walk": args.walk,
            "repeat": args.repeat,
            "method": "moderngl class methods wrapped with perf_counter, outermost call only",
            **rows,
        },
    )


if __name__ == "__main__":
    main()
