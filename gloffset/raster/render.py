"""Rasters of the offset region: ``render(shape, distance, grid)``.

Coarse to fine over the grid's levels: the coarse levels in float64 on the CPU
(:mod:`gloffset.raster.vector.levels`), the levels below the bins in fragment shaders on the
GPU (:mod:`gloffset.gl.vector_pass`), each level evaluating only children of frontier
cells. Outputs larger than the GL texture limit are rendered in tiles.
"""

from __future__ import annotations

import numpy as np

from ..ellipsoid import as_ellipsoid
from ..ellipsoidal import conformal, decide, members, thresholds
from ..errors import OptionError
from ..geometry.sphere import xyz_to_lonlat
from ..grids.conformal import ConformalRows
from ..grids.protocol import Image
from ..shape import Shape, read
from ..units import EARTH_RADIUS, RASTER_LIMIT, offset_angle, offset_metres
from . import driver
from .simplified import PIXEL_FRACTION, band_members, simplified, z_order
from .vector.curves import CurveCells

__all__ = ["render", "render_angle", "RenderError", "MAX_PIXELS"]

#: Largest output accepted (pixels); above it the result would not fit in memory.
MAX_PIXELS = 1 << 31
_OUTS = ("mask", "classes")
_BACKENDS = ("gpu", "cpu")


#: The former name of :class:`~gloffset.errors.OptionError` (a render request with a bad
#: option, an image too large), kept so that ``except RenderError`` works.
RenderError = OptionError


def _check(out, backend, grid):
    if out not in _OUTS:
        raise OptionError(f"out must be one of {', '.join(_OUTS)}, got {out!r}")
    if backend not in _BACKENDS:
        raise OptionError(f"backend must be one of {', '.join(_BACKENDS)}, got {backend!r}")
    if not isinstance(grid, Image):
        raise OptionError(
            f"grid must be a gloffset.grids grid (Equirect, Tile, Cube), got {type(grid).__name__}"
        )
    n = sum(f.width * f.height for f in grid.faces)
    if n > MAX_PIXELS:
        raise OptionError(
            f"the image has {n} pixels, more than {MAX_PIXELS}; render it in parts "
            "(Equirect.subgrid, or fewer cube pixels)"
        )


#: the mask's value per output-level class (0 outside, 2 contained)
_MASK = np.array([0, 0, 255], dtype=np.uint8)


#: Pixel centres per batch of the ellipsoidal mask.
_ELLIPSOID_BATCH = 1 << 18


def _render_on_ellipsoid(shape, distance, grid, out, backend, callback, ellipsoid, tile):
    """Return the mask of ``render(..., ellipsoid=...)``.

    ``distance`` as given (metres or a length with a unit).

    On lon/lat grids with the GPU backend (:func:`_screened_on_gpu`): two spherical GPU
    renders on the conformal sphere decide every pixel but a thin band, which is
    decided exactly on the CPU. Otherwise every pixel centre goes through the
    ellipsoidal ``contains`` (geodetic lon/lat of the centres), in batches of rows.
    """
    ell = as_ellipsoid(ellipsoid)
    assert ell is not None  # called with an ellipsoid
    _check(out, backend, grid)
    if out != "mask" or callback is not None:
        raise OptionError("with an ellipsoid, render() gives masks only (out='mask', no callback)")
    distance = offset_metres(shape, distance, ell.a, limit=RASTER_LIMIT, what="render")
    if grid.n_faces > 1:
        return np.stack(
            [
                _render_on_ellipsoid(shape, distance, f, out, backend, None, ell, tile)
                for f in grid.faces
            ]
        )
    conf = conformal(shape, ell)
    if backend == "gpu" and grid.lonlat:
        tile = _tile_limit(tile, backend)
        image = np.empty(grid.shape, dtype=np.uint8)
        for y0, x0, sub in _parts(grid, tile):
            image[y0 : y0 + sub.height, x0 : x0 + sub.width] = _screened_on_gpu(conf, sub, distance)
        return image
    lev = grid.n_levels - 1
    h, w = grid.level_shape(lev)
    image = np.empty((h, w), dtype=np.uint8)
    rows = max(1, _ELLIPSOID_BATCH // w)
    for j0 in range(0, h, rows):
        j1 = min(h, j0 + rows)
        lon, lat, chi = _centres_lonlat(grid, lev, j0, j1, w, ell)
        inside = members(conf, lon, lat, distance, chi=chi)
        image[j0:j1] = np.where(inside, 255, 0).reshape(j1 - j0, w)
    valid = grid.valid(lev)
    if valid is not None:
        image[~valid] = 0
    return image


#: The GPU renders' error bound, in pixel sizes (``render``'s accuracy contract), and
#: the multiple of it the ellipsoid's screening thresholds are moved by.
GPU_EPS, SCREEN_MARGIN = 1e-3, 4.0


def _screened_on_gpu(conf, grid, d: float) -> np.ndarray:
    """Return the ellipsoidal mask of a lon/lat grid (within the GL size limit).

    At geodesic distance ``d`` (metres) from the shape whose conformal image is ``conf``.

    :func:`gloffset.ellipsoidal.thresholds` gives signed spherical distances ``t_in``,
    ``t_out`` on the conformal sphere: a point within ``t_in`` of the image is in the
    region on the ellipsoid, a point beyond ``t_out`` is not. The GPU renders the image
    at ``t_in - m`` and ``t_out + m`` on :class:`~gloffset.grids.conformal.ConformalRows`,
    with ``m`` = :data:`SCREEN_MARGIN` times the GPU's error bound ``eps`` (1e-3 of the
    largest pixel): a GPU render is wrong only at pixels within ``eps`` of its distance or
    of a polygon boundary, so a pixel the first calls a member is within ``t_in`` (and a
    pixel the second calls outside is beyond ``t_out``) at any distance of more than
    ``2 eps``, and near zero the rules of both signs of distance agree on it. Pixels in
    between (the ratio band of the thresholds, a fraction of a pixel wide at most
    distances, plus ``2 m``) are decided exactly (:func:`gloffset.ellipsoidal.decide`).
    """
    cgrid = ConformalRows(grid, conf.ell)
    margin = SCREEN_MARGIN * GPU_EPS * cgrid.pixel_size()
    t_in, t_out = thresholds(conf, d)
    rings = bool(conf.shape.rings)

    if t_in is not None and (t_in - margin > 0.0 or rings):
        image = render_grid(conf.shape, t_in - margin, cgrid)
    else:
        image = np.zeros(grid.shape, dtype=np.uint8)
    band = np.flatnonzero(render_grid(conf.shape, t_out + margin, cgrid) > image)
    if len(band):
        last = grid.n_levels - 1
        j, i = np.divmod(band, grid.width)
        lon = np.degrees(grid.cell_lon(last, i))
        lat = np.degrees(grid.cell_lat(last, j))
        image[j, i] = np.where(
            decide(conf, lon, lat, d, band=screened(t_in, t_out, margin)), 255, 0
        )
    return image


def screened(t_in, t_out, margin: float) -> tuple[float, float]:
    """Bounds on the signed spherical distance of the pixels two GPU renders leave undecided.

    The renders at ``t_in - margin`` and ``t_out + margin``; the pixels between go to
    :func:`gloffset.ellipsoidal.decide`. A GPU render errs only within ``eps = margin /
    SCREEN_MARGIN`` of its distance or of a polygon boundary, so such a pixel lies within
    ``margin + 3 eps`` beyond the thresholds; ``2 margin`` covers that.
    """
    lo = -np.inf if t_in is None else t_in - 2.0 * margin
    return lo, t_out + 2.0 * margin


def _tile_limit(tile: int | None, backend: str) -> int:
    """Return the largest side rendered at once: ``tile``, or 8192 and the GL texture limit."""
    if tile is not None:
        return tile
    if backend != "gpu":
        return 8192
    from ..gl.context import context_info

    return min(8192, context_info()["max_texture_size"])


def _parts(grid, tile: int):
    """Return the grid cut into parts of at most ``tile`` pixels a side.

    ``(y0, x0, sub)`` per part (:meth:`Equirect.subgrid`; the grid itself when it fits).
    """
    if grid.width <= tile and grid.height <= tile:
        yield 0, 0, grid
        return
    if not grid.subgrids:
        raise OptionError(
            f"a {grid.width}x{grid.height} {type(grid).__name__} is larger than the GL limit "
            f"{tile}; use a smaller size"
        )
    for y0 in range(0, grid.height, tile):
        for x0 in range(0, grid.width, tile):
            w, h = min(tile, grid.width - x0), min(tile, grid.height - y0)
            yield y0, x0, grid.subgrid(x0, y0, w, h)


def _centres_lonlat(grid, level, j0, j1, w, ell):
    """Lon/lat and conformal latitude (degrees, flat) of the centres of rows ``j0:j1`` of ``level``.

    Straight from the rows and columns on lon/lat grids (one conformal latitude per row),
    from the unit vectors otherwise.
    """
    if grid.lonlat:
        lon = np.degrees(grid.cell_lon(level, np.arange(w)))
        lat = np.degrees(grid.cell_lat(level, np.arange(j0, j1)))
        chi = ell.conformal(lat)
        shape = (j1 - j0, w)
        lon, lat, chi = (
            np.broadcast_to(x, shape).ravel() for x in (lon, lat[:, None], chi[:, None])
        )
        return lon, lat, chi
    j, i = np.meshgrid(np.arange(j0, j1), np.arange(w), indexing="ij")
    lon, lat = xyz_to_lonlat(grid.centers(level, j.ravel(), i.ravel()))
    return lon, lat, ell.conformal(lat)


def render_grid(shape, d: float, grid) -> np.ndarray:
    """Return the GPU mask (uint8, 255 inside) of ``shape`` at ``d`` radians.

    On any grid of the levels (one within the GL size limit; a
    :class:`~gloffset.grids.conformal.ConformalRows` too), without ``render``'s checks.
    """
    return _render_one(shape, float(d), grid, backend="gpu", level=None, callback=None, mask=True)


def _render_one(shape, d, grid, *, backend, level, callback, mask, simplify=True):
    """Return the classes of ``level`` (default: the output level) or the mask.

    Cells without a place on the sphere (the grid's ``valid``) are outside.
    """
    out = _render_cells(
        shape,
        d,
        grid,
        backend=backend,
        level=level,
        callback=callback,
        mask=mask,
        simplify=simplify,
    )
    valid = grid.valid(grid.n_levels - 1 if level is None else level)
    if valid is not None:
        out[~valid] = 0
    return out


def _render_cells(shape, d, grid, *, backend, level, callback, mask, simplify=True):
    """Classes of ``level`` (default: the output level) or, with ``mask``, the mask.

    The float64 levels (:class:`~gloffset.raster.vector.curves.CurveCells`) run down to the
    bins, the GL levels (:mod:`gloffset.gl.vector_pass`) below them; ``backend="cpu"``
    runs every level in float64. A GPU mask of a shape far finer than the pixels is
    rendered from the shape simplified to a fraction of a pixel
    (:mod:`gloffset.raster.simplified`), with the same pixels.
    """
    if simplify and mask and backend == "gpu" and level is None and callback is None:
        image = _simplified_mask(shape, d, grid)
        if image is not None:
            return image
    stop = grid.n_levels - 1 if level is None else level
    bins = grid.bin_level_for(abs(d))
    if backend == "cpu" or stop <= bins:
        classes = driver.run(CurveCells(shape, d, grid), stop, callback=callback)
        return _MASK[classes] if mask else classes
    from .gpu import bin_passes, gpu_box_pairs

    cells = CurveCells(shape, d, grid, start="auto", pairs=gpu_box_pairs)

    def on_gpu(classes, lev):
        return bin_passes().run(
            grid,
            d,
            classes,
            cells.kept(lev),
            cells.arcs,
            stop_level=stop,
            callback=callback,
            values=_MASK if mask else None,
        )

    return driver.run(cells, stop, handoff=bins, backend=on_gpu, callback=callback)


def simplify_eps(grid) -> tuple[float, float]:
    """``(eps, margin)`` for a render of ``grid`` from simplified curves.

    ``eps`` :data:`~gloffset.raster.simplified.PIXEL_FRACTION` of the median row's pixel
    diameter, ``margin`` :data:`SCREEN_MARGIN` times the GPU's error bound (of the largest
    pixel).

    ``eps`` only sets the cost: every ``eps`` gives the same mask (the float64
    reference's, :mod:`gloffset.raster.simplified`). The median, not the
    smallest pixel, because a web-mercator tile's pixels shrink towards the poles (4.6
    times across a polar tile of zoom 2, 11 times across zoom 0): the smallest would
    keep most of the arcs there, for a band a few pixels narrower in the rows near the
    pole (measured on ``countries_10m``: zooms 0-1 twice as fast, the same pixels).
    """
    last = grid.n_levels - 1
    h, w = grid.level_shape(last)
    rows = np.arange(h)
    if grid.lonlat:  # every cell of a row alike
        r = grid.area_rho_cells(last, rows * w)
    else:  # a cube face: the rows' first and middle cells (smallest and largest)
        r = np.concatenate([grid.area_rho_at(last, rows, np.full(h, i)) for i in (0, w // 2)])
    eps = PIXEL_FRACTION * 2.0 * float(np.median(r))
    return eps, SCREEN_MARGIN * GPU_EPS * 2.0 * float(r.max())


def _simplified_mask(shape, d: float, grid) -> np.ndarray | None:
    """Return the GPU mask from the shape simplified to ``eps``.

    ``eps``: :data:`PIXEL_FRACTION` of the median pixel (:func:`simplify_eps`), or
    ``|d| / 8`` less the margin where that is smaller (a distance of less than a few
    pixels). Rendered at ``d - t`` and ``d + t`` (``t = eps`` plus :data:`SCREEN_MARGIN`
    times the GPU's error bound), the pixels between decided by their exact distance
    (:mod:`gloffset.raster.simplified`); None where simplifying does not pay or
    ``|d| <= 4 t``.
    """
    last = grid.n_levels - 1
    eps, margin = simplify_eps(grid)
    # a distance below a few pixels: simplify to a fraction of the distance instead
    eps = min(eps, abs(d) / 8.0 - margin)
    if not eps > 0.0 or abs(d) <= 4.0 * (eps + margin):
        return None
    s = simplified(shape, eps)
    if s is None:
        return None
    t = s.eps + margin  # s.eps <= eps: the bound the simplified curve keeps

    def one(dd):
        return _render_one(
            s, dd, grid, backend="gpu", level=None, callback=None, mask=True, simplify=False
        )

    image = one(d - t)  # within the region
    j, i = np.nonzero(one(d + t) > image)  # the band: the region's boundary is there
    if len(j):
        o = np.argsort(z_order(j, i))  # near pixels together: the cap tree's queries prune
        j, i = j[o], i[o]
        image[j, i] = np.where(band_members(shape, grid.centers(last, j, i), d), 255, 0)
    return image


def render(
    shape,
    distance: float,
    grid,
    *,
    radius: float = EARTH_RADIUS,
    out: str = "mask",
    level: int | None = None,
    callback=None,
    backend: str = "gpu",
    tile: int | None = None,
    ellipsoid=None,
) -> np.ndarray:
    """Rasterize the offset region of ``shape`` at ``distance`` on ``grid``.

    Parameters
    ----------
    shape : Shape or anything :func:`gloffset.read` accepts
    distance : float or str
        In the units of ``radius`` (metres by default), or a string with a unit
        (``"127km"``, ``"0.02rad"``); negative shrinks polygons.
    grid : gloffset.grids.Equirect, Tile, Cube or CubeFace
        A :class:`~gloffset.grids.Cube` gives (6, N, N) indexed [face, row, column],
        faces +X -X +Y -Y +Z -Z, rows and columns as in the GL cube-map table.
    out : {"mask", "classes"}
        ``"mask"``: uint8 (height, width), 255 inside the region, 0 outside, row 0
        north. ``"classes"``: uint8 classes of ``level`` (0 outside, 1 frontier,
        2 contained), shape ``grid.level_shape(level)``.
    level : int, optional
        The level for ``out="classes"`` (default: the output level, where no cell
        is frontier).
    callback : callable, optional
        ``callback(level, classes)`` after each level, coarse first: an early,
        progressively refined answer (frontier cells are undecided).
    backend : {"gpu", "cpu"}
        ``"cpu"`` runs every level in float64 numpy (the reference renderer).
    tile : int, optional
        Largest tile side (default: the GL texture limit, at most 8192).
    ellipsoid : None, "WGS84", "GRS80", (a, f) or Ellipsoid
        ``None``: the sphere of ``radius``. Otherwise ``distance`` is a geodesic length
        on the ellipsoid (metres, or a string with a length unit), the grid's latitudes
        are geodetic and polygon edges are geodesics; only ``out="mask"``. Each pixel
        centre is decided by :func:`gloffset.contains` on the ellipsoid (the spherical index on the
        conformal sphere decides all but the thin band of the ratio bound, the band is
        decided with geodesic distances), on the CPU whatever the ``backend``.

    Notes
    -----
    Accuracy: a pixel is in the mask when its centre is in the region. The GPU
    answer equals the float64 reference for every pixel whose exact distance to
    the curves differs from ``|distance|`` by more than 1e-3 of the pixel's angular
    size, and whose centre is farther than that from a polygon boundary; a cell
    reported contained or outside at any level has only descendant pixels of that
    class. A GPU mask of an input far finer than the pixels is rendered from its curves
    simplified to a quarter pixel (:mod:`gloffset.raster.simplified`): it then equals the
    float64 reference at every pixel but within 1e-3 of a pixel of a seam.
    """
    shape = read(shape)
    if ellipsoid is not None:
        return _render_on_ellipsoid(shape, distance, grid, out, backend, callback, ellipsoid, tile)
    d = offset_angle(shape, distance, radius, limit=RASTER_LIMIT, what="render")
    return render_angle(
        shape, d, grid, out=out, level=level, callback=callback, backend=backend, tile=tile
    )


def render_angle(
    shape: Shape,
    d: float,
    grid,
    *,
    out: str = "mask",
    level: int | None = None,
    callback=None,
    backend: str = "gpu",
    tile: int | None = None,
) -> np.ndarray:
    """Return :func:`render` of a read ``shape`` at the angle ``d`` (radians).

    The angle is checked by the caller (:func:`gloffset.units.offset_angle`): the one
    entry of the package's own renders, whose distances are angles already. The options
    are checked here, the accuracy is :func:`render`'s.
    """
    _check(out, backend, grid)
    if out == "classes" and level is not None and not 0 <= level < grid.n_levels:
        raise OptionError(f"level must be in 0..{grid.n_levels - 1}, got {level!r}")
    if out == "mask":
        level = None
    tile = _tile_limit(tile, backend)
    if grid.n_faces > 1:
        faces = [
            render_angle(
                shape, d, f, out=out, level=level, callback=callback, backend=backend, tile=tile
            )
            for f in grid.faces
        ]
        return np.stack(faces)
    mask = out == "mask"
    parts = list(_parts(grid, tile))
    if level is not None or len(parts) == 1:
        return _render_one(
            shape, d, grid, backend=backend, level=level, callback=callback, mask=mask
        )
    image = np.empty(grid.shape, dtype=np.uint8)
    for y0, x0, sub in parts:
        image[y0 : y0 + sub.height, x0 : x0 + sub.width] = _render_one(
            shape, d, sub, backend=backend, level=None, callback=None, mask=mask
        )
    return image
