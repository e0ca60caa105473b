"""How long ``gloffset.read`` takes: reading, checking and uniting the input.

Each read runs in a fresh process (nothing cached, nothing imported beyond gloffset and
numpy before the clock starts), three files of ``data/``: ``countries_10m`` (234 countries,
308k vertices), ``world_110m`` and ``mexico_10m``. With ``--before TREE`` (another source
tree of gloffset, e.g. a ``git archive`` of an older commit) the two trees run in turn,
round by round in alternating order, so that both see the same load of a shared machine;
the best of the rounds is kept, of the wall time and of the process's CPU time.

Usage: ``python benchmarks/read.py [--rounds 3] [--before TREE] [-k countries]``; writes
``benchmarks/results/read.json``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

from common import DATA, ROOT, write

FILES = ["countries_10m", "world_110m", "mexico_10m"]

TIMER = """
import time, gloffset
t0, c0 = time.perf_counter(), time.process_time()
s = gloffset.read({path!r})
assert gloffset.__file__.startswith({tree!r}), gloffset.__file__
print(repr(time.perf_counter() - t0), repr(time.process_time() - c0), s.n_vertices, len(s.rings))
"""


def time_in(tree: Path, path: Path) -> tuple[float, float, int, int]:
    """``(wall, cpu, vertices, rings)`` of one read of ``path`` with the tree's gloffset."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    out = subprocess.run(
        [sys.executable, "-c", TIMER.format(path=str(path), tree=str(tree))],
        cwd=tree,  # "python -c" puts the working directory first on sys.path
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    wall, cpu, nv, nr = out.stdout.split()
    return float(wall), float(cpu), int(nv), int(nr)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--before", type=Path, help="another tree to time in turn with this one")
    ap.add_argument("-k", default="", help="only the files whose name contains this")
    args = ap.parse_args(argv)
    trees = {"tree": ROOT}
    if args.before is not None:
        trees = {"before": args.before.resolve(), "tree": ROOT}
    out: dict = {"rounds": args.rounds, "trees": {k: str(v) for k, v in trees.items()}, "files": {}}
    for name in FILES:
        if args.k not in name:
            continue
        path = DATA / f"{name}.geojson"
        runs: dict = {k: {"wall_s": [], "cpu_s": []} for k in trees}
        for r in range(args.rounds):
            for k in list(trees) if r % 2 == 0 else list(trees)[::-1]:
                wall, cpu, nv, nr = time_in(trees[k], path)
                runs[k]["wall_s"].append(round(wall, 3))
                runs[k]["cpu_s"].append(round(cpu, 3))
                runs[k]["union"] = {"vertices": nv, "rings": nr}
        rec = {
            k: {**v, "best_wall_s": min(v["wall_s"]), "best_cpu_s": min(v["cpu_s"])}
            for k, v in runs.items()
        }
        if "before" in rec:
            rec["tree/before"] = {
                "wall": round(rec["tree"]["best_wall_s"] / rec["before"]["best_wall_s"], 3),
                "cpu": round(rec["tree"]["best_cpu_s"] / rec["before"]["best_cpu_s"], 3),
            }
        out["files"][name] = rec
        print(name, rec)
    print("wrote", write("read", out))


if __name__ == "__main__":
    main()
