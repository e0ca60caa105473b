"""Tile pyramids on a Dask cluster: sub-pyramids rendered by worker processes, tiles
written by one.

The pyramid is classified in this process down to a coarse zoom, the *split*: the
first zoom from ``max(zmin, 2)`` on where at least eight tiles per worker are kept
(frontier tiles, and tiles an outline crosses), or the deepest zoom. This process
writes the decided tiles of those zooms (fully inside tiles with their subtrees, tiles
an outline crosses above the split) and renders nothing: every other tile is a task,
:func:`~gloffset.tiles.tiling.driver.subpyramid`. The frontier tiles above the split are
tasks of one tile each, the kept tiles of the split zoom tasks of their subtrees down
to the deepest zoom. A worker starts from the task's cell as the split classified it
(its candidate arcs, inside statuses and class: what the whole run has for it, since a
cell's lists and classes depend on its ancestors only) and returns the PNG bytes of its
tiles, each distinct image once. Tasks are submitted subtrees of frontier tiles first
(tiles kept only for an outline are cheap) and their tiles are written as they come
back, so the output is byte-identical to a run in one process (MBTiles rows, XYZ files
and PMTiles archives do not depend on the order of writes) and an interrupted run
resumes like any other: a task skips the tiles the output has.

Workers are processes started with spawn (Dask's default: a process must not fork once
it has a GL context); each makes its one GL context lazily, on its first frontier tile.
The shape travels without what was derived from it (:class:`gloffset.shape.Derived`):
each worker derives what its tasks need once. ``scheduler=`` uses a running cluster;
its workers need gloffset importable.
"""

from __future__ import annotations

import os

import numpy as np

from ...errors import OptionError

__all__ = ["run_distributed"]

#: tasks per worker at least, where the pyramid has that many tiles to split
TASKS_PER_WORKER = 8


def _have_of(have: set, tasks) -> list[set]:
    """Per task ``(tile, forced, start, last)``: the tiles of ``have`` that are its tile
    or below it down to zoom ``last`` (grouped in one pass over ``have``)."""
    groups: dict = {}
    for zr in {tile[0] for tile, _, _, last in tasks if last > tile[0]}:
        for z, x, y in have:
            if z >= zr:
                groups.setdefault((zr, x >> (z - zr), y >> (z - zr)), set()).add((z, x, y))
    out = []
    for tile, _, _, last in tasks:
        if last > tile[0]:
            out.append({t for t in groups.get(tile, ()) if t[0] <= last})
        else:
            out.append({tile} & have)
    return out


def _client(workers, scheduler):
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise OptionError(
            "pyramids on several workers need Dask: pip install 'gloffset[dask]'"
        ) from None
    if scheduler is not None:
        return Client(scheduler), None
    import dask

    # Mesa's llvmpipe draws on as many threads as the machine has cores, in each
    # worker: the workers share the cores instead (where the user has not chosen)
    env = {}
    if "LP_NUM_THREADS" not in os.environ:
        env["LP_NUM_THREADS"] = str(max(1, (os.cpu_count() or 1) // int(workers)))
    # Dask sets MALLOC_TRIM_THRESHOLD_ in its workers to give memory back to the system
    # sooner; glibc then stops raising its mmap threshold, so every large numpy
    # temporary is mapped and zeroed afresh: a pyramid's tasks ran half as fast
    with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}):
        cluster = LocalCluster(
            n_workers=int(workers),
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            env=env,
        )
    return Client(cluster), cluster


async def _warm() -> None:
    """Import what a task needs (on each worker, while the split is made; a coroutine
    so that the call does not wait for it)."""
    from ...gl import vector_pass  # noqa: F401
    from ...raster import render  # noqa: F401  (the task module itself is imported by Dask)


def run_distributed(job, store, have, progress, stats, *, run, task, workers=None, scheduler=None):
    """Write the pyramid ``job`` into ``store`` with its tiles rendered on a Dask cluster.

    ``run(split, first, count, last)`` classifies the zooms down to the split and writes
    their decided tiles (see :class:`gloffset.tiles.tiling.driver.Part`); it returns the tasks
    ``(tile, forced class, start, last zoom)`` and the progress tracker.
    ``task(job, tile, have, start, last)`` (importable by the workers) renders one
    task's tiles from ``start``, the tile's level as the split classified it (so no
    worker walks the coarse zooms again).
    """
    zlo, zhi = job.zlo, job.zhi
    if workers is not None and not (isinstance(workers, (int, np.integer)) and workers >= 1):
        raise OptionError(f"workers must be a positive integer, got {workers!r}")
    # the workers start (and import) while this process classifies the coarse zooms
    client, cluster = _client(workers, scheduler)
    try:
        from distributed import as_completed

        client.run(_warm, wait=False)
        n = workers if workers is not None else (len(client.scheduler_info()["workers"]) or 1)
        tasks, track = run(max(zlo, 2), TASKS_PER_WORKER * int(n), zhi)
        # subtrees before single tiles, frontier roots (forced class: none) first: they
        # hold the rendering
        tasks = sorted(tasks, key=lambda t: (t[3] == t[0][0], t[1] != 255))
        job_f = client.scatter(job, broadcast=True)
        futures = [
            client.submit(task, job_f, tile, mine, start, last, pure=False)
            for (tile, _, start, last), mine in zip(tasks, _have_of(have, tasks))
        ]
        track.start_tasks(len(futures))
        for fut in as_completed(futures):
            groups, part = fut.result()
            for tiles, data in groups:
                store.put_many(tiles, data)
            store.commit()
            _merge(stats, part)
            track.task_done(part.rendered + part.painted, part.inside, part.present)
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
