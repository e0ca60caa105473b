"""The arc records of the frontier bins and their cluster headers, made on the GL context
(``shaders/arc_records.comp``) and left there for the level passes.

The planner (:func:`gloffset.raster.gpu.bin_plan`) hands over the candidate pairs (bin,
arc) with their codes, the float64 bin centres, the arcs' float64 columns arc by arc
(:attr:`gloffset.edges.CurveArcs.rows`) and the clusters' ranges; three dispatches
make the records (``shaders/lib/arcs.glsl``), the cluster headers and their order by
``Dmin`` within each bin, into storage buffers that :class:`gloffset.gl.vector_pass.VectorPasses`
binds as they are (nothing is read back).

Accuracy: every record word but ``t0.x`` has the bits of the numpy twin
(:func:`gloffset.raster.records.records`) where the device's double ``+`` and ``*`` are
IEEE and its cast to float rounds to nearest (llvmpipe, NVIDIA;
``tests/test_records_gpu.py`` checks them); ``t0.x``, ``rho`` and ``S`` are bounds of
their own, as rigorous as the twin's (they only cull, so the classes are the same). A
word that numpy makes a subnormal float (``h`` within 1e-38 of zero and positive) may come
as +0 where a device flushes subnormals (its sign, what ``orient(a, b, c)`` takes from it,
is kept; no test here has met one).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .arcs import arc_buffer
from .context import context_info, get_context, made, shared
from .shaders import load_source

__all__ = ["DeviceRecords", "RecordsPass", "records_pass", "records_pass_made"]

_LOCAL = 64
_MAX_GROUPS = 65535  # work groups per dispatch dimension (the GL minimum of the limit)
#: llvmpipe ends a shader loop after 65535 iterations: the ORDER pass loops over a bin's
#: clusters.
MAX_BIN_CLUSTERS = 65535
#: Largest buffer (bytes) the pass keeps for its next run: a fresh one costs its pages
#: again (about 7 ms for 13 MB on llvmpipe; the records of a million pairs take 96 MB).
KEEP_BYTES = 1 << 27


@dataclass
class DeviceRecords:
    """The records and the sorted cluster headers in GL storage buffers (owned: whoever
    draws with them releases them, :meth:`release`)."""

    records: Any  # moderngl.Buffer, (pairs, 6) vec4
    clusters: Any  # moderngl.Buffer, (clusters, 2) uvec4
    pairs: int
    n_clusters: int
    #: the pass that made them, which keeps the buffers for its next run on release
    pool: Any = None

    def read(self) -> tuple[np.ndarray, np.ndarray]:
        """The records (pairs, 6, 4) float32 and headers (clusters, 2, 4) uint32, read
        back (for checks: a render never reads them)."""

        def read(buf, n: int, dtype) -> np.ndarray:
            return np.frombuffer(buf.read(size=n), dtype=dtype) if n else np.zeros(0, dtype)

        rec = read(self.records, 96 * self.pairs, np.float32)
        hdr = read(self.clusters, 32 * self.n_clusters, np.uint32)
        return rec.reshape(-1, 6, 4), hdr.reshape(-1, 2, 4)

    def release(self) -> None:
        pool, self.pool = self.pool, None
        for slot, b in (("records", self.records), ("clusters", self.clusters)):
            if pool is None or not pool.keep(slot, b):
                b.release()


class RecordsPass:
    """The three compiled compute programs and :meth:`run` (one per GL thread)."""

    def __init__(self):
        self.ctx = get_context()
        self.max_bytes = context_info()["max_storage_block_size"]
        #: buffers kept for the next run: the temporaries by binding, and the records and
        #: headers that a drawing handed back (:meth:`DeviceRecords.release`)
        self.kept: dict[Any, Any] = {}
        self.progs = {
            key: self.ctx.compute_shader(load_source("arc_records.comp", defines)[0])
            for key, defines in (
                ("records", None),
                ("clusters", {"CLUSTERS": 1}),
                ("order", {"ORDER": 1}),
            )
        }

    def fits(self, pairs: int, arcs: int, clusters: int, bin_clusters: int) -> bool:
        """Whether the buffers of ``pairs`` records of ``arcs`` arcs and ``clusters``
        clusters (at most ``bin_clusters`` in a bin) stay within one storage block each."""
        return (
            96 * max(pairs, 1) <= self.max_bytes
            and 8 * 20 * max(arcs, 1) <= self.max_bytes
            and 32 * max(clusters, 1) <= self.max_bytes
            and bin_clusters < MAX_BIN_CLUSTERS
            and pairs < 1 << 31
        )

    def _dispatch(self, prog, count: int) -> None:
        groups = max(1, -(-count // _LOCAL))
        gy = -(-groups // _MAX_GROUPS)
        prog["u_count"] = count
        prog.run(group_x=-(-groups // gy), group_y=gy)
        self.ctx.memory_barrier()

    def run(
        self,
        pairs: np.ndarray,
        codes: np.ndarray,
        centres: np.ndarray,
        rows: np.ndarray,
        ranges: np.ndarray,
        se: float,
        chord_e: float,
    ) -> DeviceRecords:
        """The records of ``pairs`` (n, 2) (bin, arc), ``codes`` (n,) their flags and local
        ids, ``centres`` (k, 3) float64 the bin centres, ``rows`` (arcs, 20) float64 the
        arcs' :attr:`~gloffset.edges.CurveArcs.rows`; the clusters of ``ranges`` (m, 4):
        first record, records, the bin's first cluster and the end of its clusters.
        ``se`` and ``chord_e`` are ``sin(e)`` and ``chord(e)^2`` as the host computes
        them (``e`` the distance)."""
        n, m = len(pairs), len(ranges)
        cen = np.zeros((len(centres), 4))
        cen[:, :3] = centres
        recs = self._take("records", max(96 * n, 96))
        sorted_ = None
        try:
            p = self.progs["records"]
            self._temp(0, pairs, np.uint32)
            self._temp(1, codes, np.uint32)
            self._temp(2, cen, np.float64)
            arc_buffer(rows).bind_to_storage_buffer(3)  # kept (arcs.py)
            recs.bind_to_storage_buffer(4)
            p["u_se"] = se
            p["u_chord_e"] = chord_e
            if n:
                self._dispatch(p, n)
            sorted_ = self._take("clusters", max(32 * m, 32))
            recs.bind_to_storage_buffer(0)
            self._temp(1, ranges, np.uint32)
            self._temp(2, None, reserve=max(32 * m, 32))
            self._temp(3, None, reserve=max(4 * m, 16))
            sorted_.bind_to_storage_buffer(4)
            if m:
                self._dispatch(self.progs["clusters"], m)
                self._dispatch(self.progs["order"], m)
        except BaseException:
            recs.release()
            if sorted_ is not None:
                sorted_.release()
            raise
        finally:
            self._trim()
        return DeviceRecords(recs, sorted_, n, m, self)

    def _temp(self, slot: int, a, t=None, reserve: int = 0) -> None:
        """Binds to ``slot`` a kept buffer holding ``a`` as type ``t`` (or room for
        ``reserve`` bytes), made anew where the kept one is too small."""
        data = None if a is None else np.ascontiguousarray(a, dtype=t)
        nbytes = max(reserve if data is None else data.nbytes, 16)
        buf = self.kept.get(slot)
        if buf is None or buf.size < nbytes:
            if buf is not None:
                buf.release()
            buf = self.kept[slot] = self.ctx.buffer(reserve=nbytes)
        if data is not None and data.size:
            buf.write(data)
        buf.bind_to_storage_buffer(slot)

    def _take(self, name: str, nbytes: int):
        """A buffer of at least ``nbytes`` for the records or headers (``name``): the one
        kept from an earlier run where it is large enough, else a new one."""
        buf = self.kept.pop(name, None)
        if buf is not None and buf.size >= nbytes:
            return buf
        if buf is not None:
            buf.release()
        return self.ctx.buffer(reserve=nbytes)

    def keep(self, name: str, buf) -> bool:
        """Keeps ``buf``, the records or headers (``name``) of a finished drawing, for
        the next run; False where it is too large to keep (the caller releases it)."""
        if buf.size > KEEP_BYTES:
            return False
        old = self.kept.pop(name, None)
        if old is not None:
            old.release()
        self.kept[name] = buf
        return True

    def _trim(self) -> None:
        """Release the kept temporaries larger than :data:`KEEP_BYTES`."""
        for key, buf in list(self.kept.items()):
            if isinstance(key, int) and buf.size > KEEP_BYTES:
                buf.release()
                del self.kept[key]


def records_pass() -> RecordsPass:
    """This thread's :class:`RecordsPass` (made on first use, with the GL context)."""
    return shared(RecordsPass)


def records_pass_made() -> bool:
    """Whether this thread has made its :class:`RecordsPass` (its shaders compiled): a
    further run costs no compilation."""
    return made(RecordsPass)
