"""Georeferenced rasters: GeoTIFF (and Cloud Optimized GeoTIFF) through rasterio, and
world files beside PNGs.

A :class:`Georef` is where an image lies: its affine transform in GDAL order
``(a, b, c, d, e, f)`` (``x = a col + b row + c``, ``y = d col + e row + f``, at pixel
*edges*: ``(c, f)`` is the upper-left corner of the upper-left pixel) and its CRS. For
an equirectangular grid (:meth:`gloffset.grids.Equirect.transform`) the CRS is
EPSG:4326 in lon/lat order; a grid across 180 degrees continues past 180 (west 170,
east 190), so each pixel centre is the grid's, modulo 360.

- :func:`write_geotiff`: a tiled, deflate-compressed GeoTIFF, or with ``cog=True`` a
  Cloud Optimized GeoTIFF (rasterio's COG driver, with overviews); one band per channel
  of the image (a mask is one band, an RGBA picture four). Needs rasterio (the ``geo``
  extra).
- :func:`world_file`: the text of a world file (``.pgw`` beside a ``.png``): pixel
  *centre* convention, ``A D B E C F`` one per line; :data:`WGS84_WKT` for the ``.prj``.
- :func:`read_geotiff`: a single-band GeoTIFF as an array and its :class:`Georef`.
- :func:`check_geotiff`: whether GeoTIFFs can be written here, checked before the work.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputFormatError, OutputError
from .output import replacing, write_bytes

__all__ = ["Georef", "WGS84_WKT", "check_geotiff", "world_file", "write_geotiff", "read_geotiff"]

#: The ``.prj`` of EPSG:4326 (ESRI WKT, as GIS programs expect beside a world file).
WGS84_WKT = (
    'GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],'
    'PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]]'
)


@dataclass(frozen=True)
class Georef:
    """Where an image lies: ``transform`` (GDAL order, pixel edges) and ``crs``."""

    transform: tuple
    crs: str = "EPSG:4326"
    description: str | None = None
    #: the ``.prj`` beside a world file (ESRI WKT) for a CRS other than EPSG:4326
    prj: str | None = None


def world_file(ref: Georef) -> str:
    """The world file of an image placed by ``ref``: ``A D B E C F`` (pixel centres)."""
    a, b, c, d, e, f = ref.transform
    cx = c + 0.5 * a + 0.5 * b  # the centre of the upper-left pixel
    cy = f + 0.5 * d + 0.5 * e
    return "\n".join(repr(float(v)) for v in (a, d, b, e, cx, cy)) + "\n"


def write_world_files(target, ref: Georef) -> None:
    """``NAME.pgw`` (or ``.tfw``/``.wld`` by the image's extension) and ``NAME.prj``
    beside the image ``target``."""
    path = Path(target)
    ext = {".png": ".pgw", ".tif": ".tfw", ".tiff": ".tfw"}.get(path.suffix.lower(), ".wld")
    write_bytes(path.with_suffix(ext), world_file(ref).encode())
    if ref.prj is not None:
        write_bytes(path.with_suffix(".prj"), (ref.prj + "\n").encode())
    elif ref.crs == "EPSG:4326":
        write_bytes(path.with_suffix(".prj"), (WGS84_WKT + "\n").encode())


def _rasterio():
    try:
        import rasterio
    except ImportError:
        raise OutputError(
            "writing or reading a GeoTIFF needs rasterio: pip install 'gloffset[geo]'"
        ) from None
    return rasterio


def check_geotiff() -> None:
    """Raise :class:`~gloffset.errors.OutputError` when GeoTIFFs cannot be written here
    (rasterio, the ``geo`` extra, is not installed): for a command to refuse before its
    work."""
    _rasterio()


def write_geotiff(
    target,
    image: np.ndarray,
    ref: Georef,
    *,
    cog: bool = False,
    nodata: float | None = None,
    tags: dict[str, str] | None = None,
) -> None:
    """Write ``image`` ((h, w) or (h, w, bands), uint8 or float32: the bands keep its
    dtype) as a GeoTIFF placed by ``ref``: tiled (256 x 256) and deflate-compressed, or a
    Cloud Optimized GeoTIFF with ``cog``; ``nodata``, if given, is the bands' nodata value;
    ``tags`` are added to the dataset's metadata (beside ``DESCRIPTION``).
    Written under a temporary name and moved into place (never a half-written file),
    with the permission bits of a new file (the umask's) or of the file it replaces."""
    rasterio = _rasterio()
    from rasterio.transform import Affine

    if os.fspath(target) == "-":
        raise OutputError("a GeoTIFF cannot go to standard output; give a file name")
    arr = image if image.ndim == 3 else image[..., None]
    h, w, n = arr.shape
    profile = {
        "width": w,
        "height": h,
        "count": n,
        "dtype": arr.dtype.name,
        "crs": ref.crs,
        "transform": Affine(*ref.transform),
        "compress": "deflate",
    }
    if nodata is not None:
        profile["nodata"] = nodata
    if n == 4:
        profile["photometric"] = "RGB"
    path = Path(target)
    if cog:
        profile.update(driver="COG", blocksize=256, overview_resampling="nearest")
    else:
        profile.update(driver="GTiff", tiled=True, blockxsize=256, blockysize=256)
        if n == 4:
            profile["alpha"] = "NON-PREMULTIPLIED"  # the 4th band is alpha (ExtraSamples)
    try:
        with replacing(path) as tmp, rasterio.open(tmp, "w", **profile) as dst:
            dst.write(np.moveaxis(arr, -1, 0))
            if n == 4:
                from rasterio.enums import ColorInterp

                dst.colorinterp = [
                    ColorInterp.red,
                    ColorInterp.green,
                    ColorInterp.blue,
                    ColorInterp.alpha,
                ]
            if ref.description:
                dst.update_tags(DESCRIPTION=ref.description)
            if tags:
                dst.update_tags(**tags)
    except rasterio.errors.RasterioError as exc:
        raise OutputError(f"cannot write GeoTIFF {str(path)!r}: {exc}") from None


def read_geotiff(path) -> tuple[np.ndarray, Georef]:
    """The first band of a GeoTIFF and where it lies; refuses a rotated or sheared
    transform and any CRS but geographic WGS84 lon/lat (EPSG:4326, OGC:CRS84)."""
    rasterio = _rasterio()
    try:
        with rasterio.open(path) as src:
            band = src.read(1)
            t, crs = src.transform, src.crs
    except rasterio.errors.RasterioError as exc:
        raise InputFormatError(f"cannot read GeoTIFF {str(path)!r}: {exc}") from None
    if crs is None:
        raise InputFormatError(f"{str(path)!r} has no CRS: gloffset needs lon/lat (EPSG:4326)")
    if crs.to_epsg() != 4326 and crs.to_string() not in ("OGC:CRS84", "EPSG:4326"):
        raise InputFormatError(
            f"{str(path)!r} is in {crs.to_string()}; gloffset reads lon/lat rasters "
            "(EPSG:4326) only: reproject it first (gdalwarp -t_srs EPSG:4326)"
        )
    if t.b != 0 or t.d != 0 or t.a <= 0 or t.e >= 0:
        raise InputFormatError(
            f"{str(path)!r} is rotated or not north-up (transform {tuple(t)[:6]}); "
            "gloffset reads north-up lon/lat rasters only"
        )
    return band, Georef((t.a, t.b, t.c, t.d, t.e, t.f))
