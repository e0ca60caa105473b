"""Tile pyramids on a Dask cluster: sub-pyramids rendered by worker processes, tiles
written by one.

The pyramid is walked in this process down to a coarse zoom: the first zoom from
``max(zmin, 2)`` on where at least eight tiles per worker are kept (frontier tiles, and
tiles an outline crosses), or the zoom before the deepest. Everything down to that zoom
is written here as in a single-process run. Each kept tile of that zoom is the root of a
task, :func:`~gloffset.raster.tiles.subpyramid`: a worker starts from the root's cell as
the split classified it (its candidate arcs, inside statuses and class: what the whole
run has for it, since a cell's lists and classes depend on its ancestors only), renders
the root's descendants down to the deepest zoom and returns their PNG bytes, each
distinct image once. Tasks are submitted frontier tiles first (tiles kept only for an
outline are cheap) and their tiles are written as they come back, so the output is
byte-identical to a run in one process (MBTiles rows, XYZ files and PMTiles archives do not
depend on the order of writes) and an interrupted run resumes like any other: a task
skips the tiles the output has.

Workers are processes started with spawn (Dask's default: a process must not fork once
it has a GL context); each makes its one GL context lazily, on its first frontier tile.
``scheduler=`` uses a running cluster; its workers need gloffset importable.
"""

from __future__ import annotations

import numpy as np

from ..errors import OptionError

__all__ = ["run_distributed"]

#: tasks per worker at least, where the pyramid has that many tiles to split
TASKS_PER_WORKER = 8


def _in_subtree(have: set, root) -> set:
    zr, xr, yr = root
    return {(z, x, y) for z, x, y in have if z > zr and (x >> (z - zr), y >> (z - zr)) == (xr, yr)}


def _client(workers, scheduler):
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise OptionError(
            "pyramids on several workers need Dask: pip install 'gloffset[dask]'"
        ) from None
    if scheduler is not None:
        return Client(scheduler), None
    cluster = LocalCluster(
        n_workers=int(workers), threads_per_worker=1, processes=True, dashboard_address=None
    )
    return Client(cluster), cluster


def run_distributed(job, store, have, progress, stats, *, run, task, workers=None, scheduler=None):
    """Write the pyramid ``job`` into ``store`` with its sub-pyramids on a Dask cluster.

    ``run(split, first, count, last)`` writes the zooms down to the split (see
    :class:`gloffset.raster.tiles.Part`) and returns the roots and the progress tracker;
    ``task(job, root, have, start)`` (importable by the workers) renders one root's
    subtree from ``start``, the root's level as the split classified it (so no worker
    walks the coarse zooms again).
    """
    zlo, zhi = job[2], job[3]
    if workers is not None and not (isinstance(workers, (int, np.integer)) and workers >= 1):
        raise OptionError(f"workers must be a positive integer, got {workers!r}")
    n = workers if workers is not None else 1
    first = max(zlo, 2)
    roots, track = run(first, TASKS_PER_WORKER * int(n), zhi - 1)
    if not roots:  # the pyramid ended above the split: written, and finished
        return
    # frontier roots (forced class: none) first: they hold the rendering
    roots = sorted(roots, key=lambda r: r[1] != 255)
    client, cluster = _client(workers, scheduler)
    try:
        from distributed import as_completed

        job_f = client.scatter(job, broadcast=True)
        futures = [
            client.submit(task, job_f, root, _in_subtree(have, root), start, pure=False)
            for root, _, start in roots
        ]
        for fut in as_completed(futures):
            groups, part = fut.result()
            for tiles, data in groups:
                store.put_many(tiles, data)
                track.tick(light=len(tiles))
            store.commit()
            _merge(stats, part)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    track.finish()


def _merge(stats, part) -> None:
    for name in ("rendered", "empty", "inside", "painted", "outside", "present", "render_calls"):
        setattr(stats, name, getattr(stats, name) + getattr(part, name))
    for z, counts in part.zooms.items():
        mine = stats.zooms.setdefault(z, dict.fromkeys(counts, 0))
        for k, v in counts.items():
            mine[k] = mine.get(k, 0) + v
