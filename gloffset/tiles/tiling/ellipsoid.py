"""Tile pyramids on the ellipsoid (``tiles.pyramid(..., ellipsoid="WGS84")``).

Zoom by zoom from the root tile, each candidate tile (a child of a frontier tile of
the zoom above) is classified on the ellipsoid's conformal sphere
(:mod:`gloffset.ellipsoidal`): the tile, a lon/lat rectangle, maps to a lon/lat
rectangle there (same longitudes, conformal latitudes), bounded by a cap of centre
``c`` and radius ``r``. With ``s`` the signed spherical distance to the shape's image
(1-Lipschitz) and ``t_in``, ``t_out`` the thresholds at which the spherical region
proves membership and non-membership on the ellipsoid
(:func:`gloffset.ellipsoidal.thresholds`), ``s(c) + r < t_in`` makes the whole tile
(and its descendants) inside, ``s(c) - r > t_out`` the whole tile outside; the other
tiles are frontier tiles, rendered as :func:`gloffset.render` on the ellipsoid does
(two spherical GPU renders on the conformal sphere, the frontier tiles of a zoom
batched, and the thin band between them decided exactly: :func:`frontier_masks`) and
written when a pixel is inside. So each tile equals ``render(shape, d, Tile(z, x, y),
ellipsoid=...)``.
"""

from __future__ import annotations

import numpy as np

from ...ellipsoidal import conformal, decide, signed_distance, thresholds
from ...geometry.sphere import angle, lonlat_to_xyz
from ...grids.mercator import Tile, lat_at
from ...raster.render import GPU_EPS, SCREEN_MARGIN, screened
from .ondemand import tile_masks

__all__ = ["run_ellipsoid_pyramid", "tile_caps"]

#: Samples along each side of a tile for its cap's radius (the farthest point of a
#: small lon/lat rectangle from its centre is a corner; the samples and a relative
#: margin cover larger ones).
_SIDE = 9
#: Relative and absolute margins on the caps' radii.
_MARGIN = (1e-6, 1e-12)


def tile_caps(ell, z: int, xs, ys):
    """Caps (centres, radii in rad) on the conformal sphere of ``ell`` holding the tiles
    ``z/xs/ys``."""
    n = float(1 << z)
    xs, ys = np.asarray(xs, dtype=np.float64), np.asarray(ys, dtype=np.float64)
    west, east = xs / n * 360.0 - 180.0, (xs + 1) / n * 360.0 - 180.0

    def lat(y):
        return np.degrees(np.arctan(np.sinh(np.pi * (1.0 - 2.0 * y / n))))

    north, south = ell.conformal(lat(ys)), ell.conformal(lat(ys + 1))
    clon, clat = 0.5 * (west + east), 0.5 * (north + south)
    c = lonlat_to_xyz(clon, clat)
    t = np.linspace(0.0, 1.0, _SIDE)[None, :]
    along = west[:, None] + (east - west)[:, None] * t  # longitudes along a parallel
    up = south[:, None] + (north - south)[:, None] * t  # latitudes along a meridian
    ones = np.ones_like(t)
    sides = [
        (along, north[:, None] * ones),
        (along, south[:, None] * ones),
        (west[:, None] * ones, up),
        (east[:, None] * ones, up),
    ]
    r = np.zeros(len(xs))
    for lo, la in sides:
        pts = lonlat_to_xyz(lo.ravel(), la.ravel()).reshape(len(xs), -1, 3)
        r = np.maximum(r, angle(pts, c[:, None, :]).max(axis=1))
    # a tile wider than a quarter turn: no useful cap
    r = np.where(east - west > 90.0, np.pi, r * (1.0 + _MARGIN[0]) + _MARGIN[1])
    return c, r


def classify_tiles(conf, m: float, z: int, xs, ys):
    """``(inside, outside)`` flags of tiles ``z/xs/ys`` for signed distance ``m``."""
    t_in, t_out = thresholds(conf, m)
    c, r = tile_caps(conf.ell, z, xs, ys)
    s = signed_distance(conf, c)
    slack = 1e-12
    inside = np.zeros(len(c), bool) if t_in is None else s + r < t_in - slack
    outside = np.zeros(len(c), bool) if t_out is None else s - r > t_out + slack
    return inside, outside


def run_ellipsoid_pyramid(job, ell, store, have, stats):
    """Write the tiles of ``job`` (a :class:`~gloffset.tiles.tiling.job.PyramidJob`,
    ``job.d`` on the sphere of radius ``ell.a``) into ``store`` (skipping ``have``):
    contained tiles and their descendants as one full image, frontier tiles rendered
    (:func:`frontier_masks`, with :func:`gloffset.tiles.tiling.ondemand.tile_masks`)."""
    shape, m, size, style = job.shape, job.d * ell.a, job.size, job.style
    zlo, zhi = zooms = job.zlo, job.zhi
    full = style.encode(np.ones((size, size), dtype=bool))
    conf = conformal(shape, ell)
    xs, ys = np.zeros(1, np.int64), np.zeros(1, np.int64)
    for z in range(zhi + 1):
        if len(xs) == 0:
            break
        inside, outside = classify_tiles(conf, m, z, xs, ys)
        front = ~inside & ~outside
        stats.zooms[z] = {
            "contained": int(inside.sum()),
            "outside": int(outside.sum()),
            "frontier": int(front.sum()),
        }
        for x, y in zip(xs[inside], ys[inside]):
            _write_subtree(store, have, stats, full, z, int(x), int(y), zooms)
        if z >= zlo:
            stats.outside += int(outside.sum())
            todo = []
            for x, y in zip(xs[front], ys[front]):
                key = (z, int(x), int(y))
                if key in have:
                    stats.present += 1
                else:
                    todo.append(key[1:])
            for key, mask in frontier_masks(conf, m, z, todo, size, tile_masks).items():
                data = style.encode(mask)
                stats.rendered += 1
                if data is None:
                    stats.empty += 1
                else:
                    store.put(z, *key, data)
            store.commit()
        xs = np.repeat(2 * xs[front], 4) + np.tile([0, 1, 0, 1], int(front.sum()))
        ys = np.repeat(2 * ys[front], 4) + np.tile([0, 0, 1, 1], int(front.sum()))


#: Conformal latitude (rad) spanned by a group of tile rows sharing their thresholds.
GROUP = 0.05


def frontier_masks(conf, m: float, z: int, tiles, size: int, masks) -> dict:
    """The ellipsoidal masks of tiles ``(x, y)`` of zoom ``z``, equal to ``render(shape,
    m, Tile(z, x, y, size), ellipsoid=...)``: the tiles rendered together on the
    conformal sphere at the thresholds moved by the GPU's error bound (``masks``, see
    :func:`gloffset.raster.render._screened_on_gpu` for the argument), the pixels
    between the two decided exactly (:func:`gloffset.ellipsoidal.decide`). The largest
    pixel of a zoom on the conformal sphere is at the equator, within ``2 pi sqrt(2) /
    (2^z size)`` across.

    The tiles go in groups of rows spanning about :data:`GROUP` of conformal latitude,
    each with the thresholds of its latitudes (:func:`gloffset.ellipsoidal.thresholds`
    with a window): the band between them is then the scale's variation over a few
    degrees, not over the whole ellipsoid (at 127 km: 11 m at 5 degrees, 39 m at 20, 60 m
    at 45, against 427 m), and far fewer pixels take the exact decision; larger groups
    would leave wider bands, smaller ones more GPU runs (on Mexico at 127 km, 0.05 and
    0.1 alike for z0-10, 4.0-4.2 s; for z0-12, where the band's pixels weigh more, 13.7 s
    with 0.05 against 15.8-16.2 s with 0.1, 13.6 s with 0.025 and 14.6 s with 0.035)."""
    if not tiles:
        return {}
    margin = SCREEN_MARGIN * GPU_EPS * 2.0 * np.pi * np.sqrt(2.0) / ((1 << z) * size) * 1.01
    n = float(1 << z)
    ys = np.array([y for _, y in tiles], dtype=np.float64)
    north = np.radians(conf.ell.conformal(np.degrees(lat_at(ys, n))))
    south = np.radians(conf.ell.conformal(np.degrees(lat_at(ys + 1.0, n))))
    key = np.floor(0.5 * (north + south) / GROUP).astype(np.int64)
    out = {}
    for g in np.unique(key):
        sel = np.flatnonzero(key == g)
        lo, hi = float(south[sel].min()), float(north[sel].max())
        group = [tiles[i] for i in sel]
        t_in, t_out = thresholds(conf, m, window=(0.5 * (lo + hi), 0.5 * (hi - lo)))
        out.update(_group_masks(conf, m, z, group, size, masks, t_in, t_out, margin))
    return out


def _group_masks(conf, m, z, tiles, size, masks, t_in, t_out, margin) -> dict:
    """:func:`frontier_masks` of tiles sharing the thresholds ``t_in``, ``t_out``."""
    rings = bool(conf.shape.rings)
    if t_in is not None and (t_in - margin > 0.0 or rings):
        sure = masks(conf.shape, t_in - margin, z, tiles, size=size, ell=conf.ell)
    else:
        sure = {t: np.zeros((size, size), dtype=bool) for t in tiles}
    maybe = masks(conf.shape, t_out + margin, z, tiles, size=size, ell=conf.ell)
    out, where, lons, lats = {}, [], [], []
    for x, y in tiles:  # the band pixels of every tile, decided in one call
        image = out[(x, y)] = sure[(x, y)].copy()
        band = np.flatnonzero(maybe[(x, y)] & ~image)
        if len(band):
            grid = Tile(z, x, y, size)
            last = grid.n_levels - 1
            j, i = np.divmod(band, size)
            lons.append(np.degrees(grid.cell_lon(last, i)))
            lats.append(np.degrees(grid.cell_lat(last, j)))
            where.append((image, band))
    if where:
        ratio_band = screened(t_in, t_out, margin)
        inside = decide(conf, np.concatenate(lons), np.concatenate(lats), m, band=ratio_band)
        k = 0
        for image, band in where:
            image.ravel()[band] = inside[k : k + len(band)]
            k += len(band)
    return out


def _write_subtree(store, have, stats, full, z, x, y, zooms):
    """A fully inside tile and its descendants within ``zooms``."""
    zlo, zhi = zooms
    for zz in range(max(z, zlo), zhi + 1):
        k = zz - z
        span = np.arange(1 << k)
        tiles = [(zz, (x << k) + int(i), (y << k) + int(j)) for j in span for i in span]
        new = [t for t in tiles if t not in have]
        stats.present += len(tiles) - len(new)
        if new:
            store.put_many(new, full)
        stats.inside += len(new)
