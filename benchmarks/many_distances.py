"""Five distances at once against five single runs: renders and a tile pyramid.

``python benchmarks/many_distances.py [--size 4096x2048] [--zooms 0-8] [--quick]``

Each case times, in one process and the same run:

* *single*: for each distance, the input read from its file and rendered alone
  (``gloffset.read`` + ``gloffset.render``, or ``gloffset.tiles.pyramid`` from the path),
  as five separate commands would, less their interpreter start, GL context and shader
  compilation (done once, before any timing, for both);
* *many*: ``gloffset.render_many`` (or ``gloffset.tiles.pyramids``) on the path, the
  five distances from one read.

Every mask of *many* is checked equal to the single run's (every tile, for the
pyramid). The cases: Mexico and ``countries_10m`` at 4096 x 2048, Mexico's pyramid at
zooms 0-8 (256-pixel tiles, MBTiles).

Then the commands themselves (skipped with ``--no-commands``), on Mexico: five ``gloffset
render`` (and ``gloffset tiles``) commands, one per distance, against one command with the
five distances, each a new process timed end to end: what a user runs, with the
interpreter start, the input read, the GL context and the shader compilation that the one
command shares between its distances (the issue counts them in the gain). The outputs are
checked equal. Each case is run cold once (``--repeat`` more
times when asked, the best kept). Writes ``benchmarks/results/many_distances.json``.
"""

from __future__ import annotations

import argparse
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from common import DATA, write  # noqa: E402

import gloffset  # noqa: E402
from gloffset.grids import Equirect  # noqa: E402

DISTANCES = ["10km", "50km", "127km", "250km", "500km"]


def timed(fn):
    t = time.perf_counter()
    out = fn()
    return time.perf_counter() - t, out


def best(fn, repeat: int):
    runs = [timed(fn) for _ in range(repeat)]
    return min(t for t, _ in runs), runs[-1][1]


def render_case(path: Path, size: tuple[int, int], repeat: int) -> dict:
    grid = Equirect(*size)

    def single():
        return [gloffset.render(gloffset.read(path), d, grid) for d in DISTANCES]

    def many():
        return gloffset.render_many(path, DISTANCES, grid)

    t_single, want = best(single, repeat)
    t_many, got = best(many, repeat)
    assert all(np.array_equal(a, b) for a, b in zip(got, want)), "masks differ"
    return _record(path, f"{size[0]}x{size[1]}", t_single, t_many)


def _tiles(path: Path) -> dict:
    db = sqlite3.connect(path)
    tiles = {(z, x, r): bytes(b) for z, x, r, b in db.execute("SELECT * FROM tiles")}
    db.close()
    return tiles


def pyramid_case(path: Path, zooms: str, repeat: int) -> dict:
    tmp = Path(tempfile.mkdtemp(prefix="many_distances_"))
    names = [f"t_{d}.mbtiles" for d in DISTANCES]

    def single():
        (tmp / "single").mkdir(exist_ok=True)
        outs = [tmp / "single" / n for n in names]
        for d, out in zip(DISTANCES, outs):
            gloffset.tiles.pyramid(path, d, zooms, out, overwrite=True)
        return outs

    def many():
        (tmp / "many").mkdir(exist_ok=True)
        outs = [tmp / "many" / n for n in names]
        gloffset.tiles.pyramids(path, DISTANCES, zooms, outs, overwrite=True)
        return outs

    t_single, want = best(single, repeat)
    t_many, got = best(many, repeat)
    assert all(_tiles(a) == _tiles(b) for a, b in zip(got, want)), "tiles differ"
    rec = _record(path, f"z{zooms}", t_single, t_many)
    rec["frontier_tiles"] = _overlap([_tiles(a) for a in got])
    print(f"{'':>14} frontier tiles: {rec['frontier_tiles']}", flush=True)
    return rec


def command_case(path: Path, args: list[str], what: str, outputs) -> dict:
    """Five ``gloffset`` commands (one distance each) against one with the five distances,
    each a new process, timed end to end; ``args`` the command's other arguments with
    ``{out}`` for the output, ``outputs(folder, single)`` the files of each distance."""
    tmp = Path(tempfile.mkdtemp(prefix="many_distances_cli_"))

    def run(dist: str, out: Path) -> None:
        out.parent.mkdir(parents=True, exist_ok=True)
        cmd = [sys.executable, "-m", "gloffset", *(a.format(out=out) for a in args)]
        subprocess.run([*cmd[:4], str(path), "-d", dist, *cmd[4:]], check=True)

    t0 = time.perf_counter()
    for d in DISTANCES:
        run(d, tmp / f"single_{d}" / "out")
    t_single = time.perf_counter() - t0
    t0 = time.perf_counter()
    run(",".join(DISTANCES), tmp / "many" / "out")
    t_many = time.perf_counter() - t0
    for d, (a, b) in zip(DISTANCES, outputs(tmp)):
        same = a.read_bytes() == b.read_bytes() if a.suffix == ".png" else _tiles(a) == _tiles(b)
        if not same:
            raise SystemExit(f"the outputs of {d} differ: {a} {b}")
    rec = _record(path, what, t_single, t_many)
    rec["commands"] = True
    return rec


def _overlap(pyramids: list[dict]) -> dict:
    """The tiles partly in the region (neither empty nor the shared full tile) of each
    distance: their sum over the distances, the distinct ones, and those of two or more
    distances (the pixel work a pass shared between distances could save)."""
    seen: dict = {}
    total = 0
    for tiles in pyramids:
        blobs: dict = {}
        for blob in tiles.values():
            blobs[blob] = blobs.get(blob, 0) + 1
        full = max(blobs, key=blobs.__getitem__)  # the one image of the tiles wholly inside
        part = [key for key, blob in tiles.items() if blob != full]
        total += len(part)
        for key in part:
            seen[key] = seen.get(key, 0) + 1
    shared = sum(1 for n in seen.values() if n >= 2)
    return {"sum": total, "distinct": len(seen), "in_two_or_more": shared}


def _record(path: Path, what: str, t_single: float, t_many: float) -> dict:
    rec = {
        "input": path.name,
        "output": what,
        "distances": DISTANCES,
        "single_s": round(t_single, 3),
        "many_s": round(t_many, 3),
        "ratio": round(t_many / t_single, 3),
    }
    print(
        f"{path.stem:>14} {what:>10}: 5 single {t_single:7.2f} s, many {t_many:7.2f} s "
        f"({rec['ratio']:.2f} of the single runs)",
        flush=True,
    )
    return rec


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--size", default="4096x2048")
    ap.add_argument("--zooms", default="0-8")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--quick", action="store_true", help="Mexico only, 1024x512, zooms 0-5.")
    ap.add_argument("--out", default="many_distances", help="The results file's name.")
    ap.add_argument(
        "--no-commands", action="store_true", help="Skip the end-to-end commands' cases."
    )
    args = ap.parse_args()
    size = (1024, 512) if args.quick else tuple(int(v) for v in args.size.split("x"))
    zooms = "0-5" if args.quick else args.zooms
    from gloffset.gl.context import context_info

    device = context_info()  # the GL context, made before any timing
    mexico, world = DATA / "mexico_10m.geojson", DATA / "countries_10m.geojson"
    gloffset.render(mexico, 10e3, Equirect(64, 32))  # the shaders compiled before timing
    cases = [render_case(mexico, size, args.repeat)]
    if not args.quick:
        cases.append(render_case(world, size, args.repeat))
    cases.append(pyramid_case(mexico, zooms, args.repeat))
    if not args.no_commands:
        w, h = size
        cases.append(
            command_case(
                mexico,
                ["render", "--size", f"{w}x{h}", "-o", "{out}.png"],
                f"{w}x{h} cmd",
                lambda t: [
                    (t / f"single_{d}" / "out.png", t / "many" / f"out_{d}.png") for d in DISTANCES
                ],
            )
        )
        cases.append(
            command_case(
                mexico,
                ["tiles", "-z", zooms, "-o", "{out}.mbtiles"],
                f"z{zooms} cmd",
                lambda t: [
                    (t / f"single_{d}" / "out.mbtiles", t / "many" / f"out_{d}.mbtiles")
                    for d in DISTANCES
                ],
            )
        )
    path = write(
        args.out,
        {"device": device.get("renderer", str(device)), "repeat": args.repeat, "cases": cases},
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
