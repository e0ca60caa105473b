"""PMTiles v3 output: one file of PNG tiles, written through the ``pmtiles`` package.

A PMTiles archive is written in one go (its directories come first and are sorted by
tile id), so the writer stages the tiles in an MBTiles file beside the output
(``OUT.pmtiles.partial.mbtiles``, see :mod:`gloffset.tiles.store.mbtiles`) and builds the
archive when the pyramid is complete (:meth:`PMTilesWriter.finish`): under a temporary
name, moved into place atomically, the staging file then removed. An interrupted run
leaves the staging file, which ``resume`` continues; resuming a finished archive reads
its tiles back into a new staging file first. The result of a resumed run is the same
archive as that of one uninterrupted run.

Repeated tiles are stored once: tiles with identical bytes (every fully inside tile of a
pyramid) share one offset, and runs of consecutive tile ids with the same bytes are one
directory entry. Header: tile type PNG, tile compression none (PNG is compressed),
internal compression gzip, clustered; zooms, bounds (rounded outward to 1e-7 degree)
and centre from the pyramid's metadata, which is also stored as the archive's JSON
metadata.
"""

from __future__ import annotations

import gzip
import json
import math
import tempfile
from pathlib import Path

from ...errors import OutputError, OutputExistsError
from ...io.output import replacing
from .mbtiles import MBTilesWriter, tms_row
from .mbtiles import read_mbtiles_metadata as _staged_metadata

__all__ = ["PMTilesWriter", "read_pmtiles_metadata", "read_pmtiles"]


def _pmtiles():
    try:
        from pmtiles import tile, writer
    except ImportError:  # pragma: no cover - depends on the environment
        raise OutputError(
            "writing .pmtiles needs the pmtiles package: pip install 'gloffset[pmtiles]'"
        ) from None
    return tile, writer


class PMTilesWriter:
    """Write PNG tiles into a PMTiles v3 archive (see the module notes).

    The interface is that of :class:`~gloffset.tiles.store.mbtiles.MBTilesWriter`, plus
    :meth:`finish`, which writes the archive.
    """

    suffix = ".pmtiles"

    def __init__(self, path, metadata: dict, *, resume=False, overwrite=False):
        _pmtiles()
        self.path = Path(path)
        self.staging = self.path.with_name(self.path.name + ".partial.mbtiles")
        if self.path.exists() and not (resume or overwrite):
            raise OutputExistsError(self.path)
        if overwrite:
            self.staging.unlink(missing_ok=True)
        elif resume and self.path.exists() and not self.staging.exists():
            self._unpack()
        self.stage = MBTilesWriter(self.staging, metadata, resume=resume, overwrite=overwrite)
        self.finished = False

    def _unpack(self) -> None:
        """Read a finished archive back into a new staging file (to resume it)."""
        meta, tiles = read_pmtiles(self.path)
        with MBTilesWriter(self.staging, meta) as stage:
            for (z, x, y), data in tiles.items():
                stage.put(z, x, y, data)

    # the staging file answers everything but finish
    def metadata(self) -> dict:
        return self.stage.metadata()

    def existing(self) -> set[tuple[int, int, int]]:
        return self.stage.existing()

    def extent(self, z: int):
        return self.stage.extent(z)

    def put(self, z: int, x: int, y: int, data: bytes) -> None:
        self.stage.put(z, x, y, data)

    def put_many(self, tiles, data: bytes) -> None:
        self.stage.put_many(tiles, data)

    def set_metadata(self, values: dict) -> None:
        self.stage.set_metadata(values)

    def commit(self) -> None:
        self.stage.commit()

    def finish(self) -> None:
        """Write the archive from the staged tiles and remove the staging file."""
        self.stage.commit()
        meta: dict = self.stage.metadata()
        if "json" in meta:  # vector tiles: MBTiles' "json" row holds the vector_layers
            meta.update(json.loads(meta.pop("json")))
        rows = self.stage.db.execute(
            "SELECT map.zoom_level, map.tile_column, map.tile_row, map.tile_id FROM map"
        ).fetchall()
        try:
            with replacing(self.path) as tmp, open(tmp, "wb") as f:
                _write_archive(f, meta, rows, self._image)
        except OSError as exc:
            if isinstance(exc, OutputError):
                raise
            raise OutputError(f"cannot write {str(self.path)!r}: {exc}") from None
        self.stage.close()
        self.staging.unlink(missing_ok=True)
        self.finished = True

    def _image(self, tid: str) -> bytes:
        row = self.stage.db.execute(
            "SELECT tile_data FROM images WHERE tile_id = ?", (tid,)
        ).fetchone()
        return bytes(row[0])

    def close(self) -> None:
        """Close the staging file (kept for ``resume`` unless :meth:`finish` ran)."""
        if not self.finished:
            self.stage.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _header(meta: dict, tile) -> dict:
    """The archive header from the pyramid's metadata (bounds rounded outward)."""
    w, s, e, n = (float(v) for v in meta.get("bounds", "-180,-85.051129,180,85.051129").split(","))
    lon, lat, cz = (float(v) for v in meta.get("center", "0,0,0").split(","))
    return {
        "tile_type": tile.TileType.MVT if meta.get("format") == "pbf" else tile.TileType.PNG,
        "tile_compression": tile.Compression.NONE,
        "min_zoom": int(meta["minzoom"]),
        "max_zoom": int(meta["maxzoom"]),
        "min_lon_e7": math.floor(w * 1e7),
        "min_lat_e7": math.floor(s * 1e7),
        "max_lon_e7": math.ceil(e * 1e7),
        "max_lat_e7": math.ceil(n * 1e7),
        "center_zoom": int(cz),
        "center_lon_e7": round(lon * 1e7),
        "center_lat_e7": round(lat * 1e7),
    }


def _write_archive(f, meta: dict, rows, image) -> None:
    """Tiles ``rows`` ((z, x, tms_row, image id)) in tile-id order, each distinct image
    once, runs of equal consecutive tiles as one entry; then header and directories."""
    tile, writer = _pmtiles()
    ids = sorted((tile.zxy_to_tileid(z, x, tms_row(z, r)), tid) for z, x, r, tid in rows)
    entries: list = []
    offsets: dict[str, tuple[int, int]] = {}
    with tempfile.TemporaryFile() as data:
        length = 0
        for tileid, tid in ids:
            if tid not in offsets:
                blob = image(tid)
                offsets[tid] = (length, len(blob))
                data.write(blob)
                length += len(blob)
            off, size = offsets[tid]
            last = entries[-1] if entries else None
            if last and last.offset == off and tileid == last.tile_id + last.run_length:
                last.run_length += 1
            else:
                entries.append(tile.Entry(tileid, off, size, 1))
        header = _header(meta, tile)
        if entries:
            parts = writer.finalize_header(
                header, len(ids), entries, len(offsets), meta, True, length
            )
        else:
            parts = _empty_parts(header, meta, tile, writer)
        for part in parts:
            f.write(part)
        data.seek(0)
        while chunk := data.read(1 << 20):
            f.write(chunk)


def _empty_parts(header: dict, meta: dict, tile, writer) -> tuple[bytes, ...]:
    """Header, root directory, metadata and leaves of an archive with no tile (the region
    at the distance covers no tile: an inward offset that empties the shape). pmtiles'
    ``finalize_header`` needs a first tile; this lays the same sections out without one,
    the zooms being those asked for."""
    root, leaves, _ = writer.optimize_directories([], 16384 - 127)
    packed = gzip.compress(json.dumps(meta).encode(), mtime=0)
    header.update(
        addressed_tiles_count=0,
        tile_entries_count=0,
        tile_contents_count=0,
        clustered=True,
        internal_compression=tile.Compression.GZIP,
        root_offset=127,
        root_length=len(root),
        metadata_offset=127 + len(root),
        metadata_length=len(packed),
        leaf_directory_offset=127 + len(root) + len(packed),
        leaf_directory_length=len(leaves),
        tile_data_offset=127 + len(root) + len(packed) + len(leaves),
        tile_data_length=0,
    )
    return tile.serialize_header(header), root, packed, leaves


def read_pmtiles_metadata(path) -> dict:
    """The metadata a resumed run of the archive ``path`` continues, read only: that of its
    staged tiles when a run was interrupted, else the finished archive's (its tiles are not
    read)."""
    staging = Path(path).with_name(Path(path).name + ".partial.mbtiles")
    if staging.exists():
        return _staged_metadata(staging)
    _pmtiles()
    from pmtiles.reader import MmapSource, Reader

    try:
        with open(path, "rb") as f:
            meta = Reader(MmapSource(f)).metadata()
    except Exception as exc:  # noqa: BLE001 - the reader's errors are of many kinds
        raise OutputError(f"{str(path)!r} is not a PMTiles archive: {exc}") from None
    if isinstance(meta, (bytes, str)):
        meta = json.loads(meta)
    return {k: str(v) for k, v in meta.items()}


def read_pmtiles(path) -> tuple[dict, dict]:
    """``(metadata, {(z, x, y): png bytes})`` of a PMTiles archive (XYZ rows)."""
    from pmtiles.reader import MmapSource, Reader, all_tiles

    with open(path, "rb") as f:
        source = MmapSource(f)
        meta = Reader(source).metadata()
        tiles = {(z, x, y): bytes(data) for (z, x, y), data in all_tiles(source)}
    if isinstance(meta, (bytes, str)):
        meta = json.loads(meta)
    return meta, tiles
