"""Images in a projected CRS: :class:`Projected`, any CRS that pyproj knows.

Pixel ``(i, j)`` (row 0 at ``ymax``) of a ``width x height`` grid over the outer edges
``bounds = (xmin, ymin, xmax, ymax)`` (CRS units) has its centre at ``x = xmin + (i +
0.5) (xmax - xmin) / width``, ``y = ymax - (j + 0.5) (ymax - ymin) / height`` (in that
order of operations), and its lon/lat is pyproj's inverse to the CRS's own geographic
CRS, read as a point of the sphere like every input point. A pixel without an inverse
(outside the projection's domain) is outside every region: mask 0, field ``+inf``.

Levels are those of :mod:`gloffset.grids.base`; a cell's centre is the inverse of its
block's centre. Its bound ``rho`` covers every pixel centre of the cell, and ``rho_l >=
angle(centre, child centre) + rho_child``; pixels are decided at their centres. Two
ways (derivation: docs/design.md, "gloffset.grids.projected"):

* a formula where the projection gives one: the inverse is ``K``-Lipschitz from the
  plane to the unit sphere, ``K = 1 / (k_min a (1 - e^2))``, so ``rho = K h`` (``h`` the
  cell's half-diagonal) plus 3e-9 rad per level for the inverse's own error. Polar
  stereographic (variants A and B: EPSG:3031, 3413, 3976, UPS): ``k_min`` is the scale
  at the pole, and the whole plane is the domain; Transverse Mercator (UTM, national
  grids) within 3900 km of the central meridian: ``k_0``; Lambert azimuthal equal-area,
  conformal conic and Albers: :mod:`gloffset.grids.stretch`;
* otherwise from the pixel centres themselves (every one computed by pyproj, about
  0.5-0.7 us each): exact for the pixels, correct for any CRS, slower.

The GPU levels compute polar stereographic, LAEA, transverse Mercator and conformal conic
grids' cell centres in a GLSL function where it holds (``centres = "glsl"``,
:meth:`Projected.glsl_centres`); every other grid's come from a texture made here in
float64 from pyproj's (``centres = "texture"``): correct, slower.
"""

from __future__ import annotations

import math
import threading

import numpy as np

from ..errors import InvalidGridError
from ..geometry.caps import pad
from ..geometry.sphere import angle, lonlat_to_xyz
from .base import LevelHierarchy, check_size
from .conic import lcc_clear, lcc_glsl, lcc_params
from .laea import LAEA_PYPROJ_BOUND, laea_clear, laea_glsl, laea_params
from .polar import polar_glsl, polar_inverse, polar_params, polar_scale_min
from .protocol import GlslCentres
from .stretch import eccentricity_squared, inverse_lipschitz
from .transverse import tm_clear, tm_glsl, tm_params

__all__ = ["Projected", "polar_scale_min", "polar_inverse"]

#: Allowance (rad) per level for the inverse's error and the roundings of a formula bound.
_LEVEL_SLACK = 3e-9
#: Rows of pixels per strip when the bounds are made from every pixel centre.
_STRIP = 256


def _pyproj():
    try:
        import pyproj
    except ImportError:  # pragma: no cover - pyproj is a dependency of the files extra
        raise InvalidGridError(
            "a Projected grid needs pyproj: pip install 'gloffset[files]'"
        ) from None
    return pyproj


#: pyproj transformers and projected areas of use, per thread and CRS (making a
#: transformer costs about 1 ms: a tile pyramid makes many grids of one CRS)
_CACHE: dict = {}
_CACHE_SIZE = 64


def _cached(kind: str, crs, make):
    key = (kind, threading.get_ident(), crs.to_wkt())
    got = _CACHE.get(key)
    if got is None:
        got = make()
        if len(_CACHE) >= _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)), None)
        _CACHE[key] = got
    return got


def _inverse_transformer(crs):
    """pyproj's inverse of ``crs``: to its own geographic CRS, lon/lat order."""
    pyproj = _pyproj()
    return _cached(
        "inverse",
        crs,
        lambda: pyproj.Transformer.from_crs(crs, crs.geodetic_crs, always_xy=True),
    )


def _forward_transformer(crs):
    pyproj = _pyproj()
    return _cached(
        "forward",
        crs,
        lambda: pyproj.Transformer.from_crs(crs.geodetic_crs, crs, always_xy=True),
    )


def _as_crs(crs):
    pyproj = _pyproj()
    try:
        out = pyproj.CRS.from_user_input(crs)
    except Exception as exc:  # pyproj raises CRSError (and others for odd input)
        raise InvalidGridError(f"unknown CRS {crs!r}: {str(exc).splitlines()[0]}") from None
    if not out.is_projected:
        raise InvalidGridError(
            f"CRS {crs!r} is not a projected CRS ({out.type_name}); use Equirect for lon/lat grids"
        )
    return out


#: Transverse Mercator: the formula bound is used where every cell centre lies within this
#: distance (metres, over the scale factor) of the central meridian, where PROJ's series
#: are good to nanometres (Karney 2011: 5 nm within 3900 km)
_TM_REACH = 3.9e6


def transverse_scale_min(crs, box) -> float | None:
    """The smallest scale factor of a Transverse Mercator ``crs`` (UTM and national
    grids) over the box ``(xmin, ymin, xmax, ymax)`` (CRS units): ``k_0``, the scale on
    the central meridian (it grows away from it), where the box lies within
    :data:`_TM_REACH` of it; else None, as for other CRSs."""
    op = crs.coordinate_operation
    if op is None or op.method_name != "Transverse Mercator":
        return None
    params = {p.name: p.value for p in op.params}
    k0 = float(params.get("Scale factor at natural origin", 1.0))
    fe = params.get("False easting", 0.0)
    unit = crs.axis_info[0].unit_conversion_factor or 1.0
    reach = max(abs(box[0] - fe), abs(box[2] - fe)) * unit / k0
    return k0 if reach <= _TM_REACH else None


def _projected_area(crs) -> tuple[float, float, float, float]:
    area = crs.area_of_use
    if area is None:
        raise InvalidGridError(f"CRS {crs.name!r} has no area of use: give bounds")
    try:
        b = _forward_transformer(crs).transform_bounds(*area.bounds, densify_pts=101)
    except Exception as exc:
        raise InvalidGridError(
            f"the area of use of {crs.name!r} cannot be projected: {exc}; give bounds"
        ) from None
    if not all(math.isfinite(x) for x in b) or not (b[0] < b[2] and b[1] < b[3]):
        raise InvalidGridError(f"the area of use of {crs.name!r} does not project: give bounds")
    return (float(b[0]), float(b[1]), float(b[2]), float(b[3]))


class Projected(LevelHierarchy):
    """A ``width x height`` image in the projected CRS ``crs`` over ``bounds`` (the outer
    edges ``(xmin, ymin, xmax, ymax)`` in the CRS's units; default: the CRS's area of
    use, projected). See the module notes for the pixel centres and the bounds.

    Parameters
    ----------
    width, height : int
    crs : anything ``pyproj.CRS.from_user_input`` takes ("EPSG:3031", WKT, a PROJ string)
    bounds : (xmin, ymin, xmax, ymax), optional
    check_domain : bool, default True
        Refuse bounds that miss the CRS's area of use or where no point has an inverse
        (see Raises). False takes the bounds as given, for grids that something else
        places (a TileMatrixSet's tiles: the UPS quads reach far beyond the 60th
        parallel that bounds UPS's area of use). Either way a pixel without an inverse
        is outside every region.

    Raises
    ------
    InvalidGridError
        An unknown or non-projected CRS, bounds that are not four finite numbers with
        ``xmin < xmax`` and ``ymin < ymax``, or (with ``check_domain``) bounds that miss
        the CRS's area of use or where no point of a 9 x 9 sample has an inverse.

    Examples
    --------
    >>> g = Projected(256, 256, crs="EPSG:3031", bounds=(-3e6, -3e6, 3e6, 3e6))
    >>> lon, lat = g.pixel_lonlat(128, 128)
    >>> round(float(lat), 3)
    -89.847
    """

    width: int
    height: int
    subgrids = True
    curve_masks = False
    #: how the GPU levels get the cell centres: a texture made on the host, or the
    #: GLSL function of polar stereographic and LAEA CRSs (set per grid,
    #: :meth:`glsl_centres`)
    centres = "texture"

    def __init__(self, width: int, height: int, *, crs, bounds=None, check_domain: bool = True):
        w, h = check_size(width, height)
        self._crs = _as_crs(crs)
        self.width, self.height = w, h
        if bounds is None:
            bounds = self.area_bounds(self._crs)
        try:
            b = tuple(float(x) for x in bounds)
        except (TypeError, ValueError):
            raise InvalidGridError(
                f"bounds must be 4 numbers xmin,ymin,xmax,ymax, got {bounds!r}"
            ) from None
        if len(b) != 4 or not all(math.isfinite(x) for x in b) or not (b[0] < b[2] and b[1] < b[3]):
            raise InvalidGridError(
                f"bounds must be 4 finite numbers xmin,ymin,xmax,ymax with xmin < xmax and "
                f"ymin < ymax, got {bounds!r}"
            )
        self.bounds = b
        # the pixel frame: this grid's pixels are columns x0.. and rows y0.. of a
        # full_w x full_h grid over full (a subgrid keeps its parent's pixel centres)
        self._frame = (0, 0, w, h, b)
        if check_domain:
            self._check_domain()
        if self._takes_glsl():
            self.centres = "glsl"

    # ------------------------------------------------------------------ identity
    @property
    def crs(self):
        """The CRS (``pyproj.CRS``)."""
        return self._crs

    def _key(self):
        return (self.width, self.height, self._crs.to_wkt(), self._frame)

    def __eq__(self, other) -> bool:
        return isinstance(other, Projected) and self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())

    def __repr__(self) -> str:
        name = self._crs.to_string()
        return f"Projected({self.width}, {self.height}, crs={name!r}, bounds={self.bounds!r})"

    def __getstate__(self):
        state = dict(self.__dict__)
        state.pop("_inverse", None)
        state["_crs"] = self._crs.to_wkt()
        return state

    def __setstate__(self, state):
        state = dict(state)
        state["_crs"] = _pyproj().CRS.from_wkt(state["_crs"])
        self.__dict__.update(state)

    @staticmethod
    def area_bounds(crs) -> tuple[float, float, float, float]:
        """The area of use of ``crs`` projected to it: ``(xmin, ymin, xmax, ymax)``."""
        crs = _as_crs(crs)
        return _cached("area", crs, lambda: _projected_area(crs))

    @property
    def transformer(self):
        """pyproj's inverse: the CRS to its geographic CRS, lon/lat order."""
        return _inverse_transformer(self._crs)

    # ------------------------------------------------------------------ geometry
    def transform(self) -> tuple:
        """The affine transform in GDAL order ``(a, b, c, d, e, f)`` (pixel edges, CRS
        units): ``x = a col + c``, ``y = e row + f``."""
        xmin, ymin, xmax, ymax = self.bounds
        return ((xmax - xmin) / self.width, 0.0, xmin, 0.0, -(ymax - ymin) / self.height, ymax)

    def pixel_xy(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """CRS coordinates at fractional output-pixel coordinates ``(x, y)`` (0: the left
        and top edges; pixel centres at ``i + 0.5``)."""
        x0, y0, fw, fh, (xmin, ymin, xmax, ymax) = self._frame
        fx = np.asarray(x, dtype=np.float64) + x0
        fy = np.asarray(y, dtype=np.float64) + y0
        return xmin + fx * (xmax - xmin) / fw, ymax - fy * (ymax - ymin) / fh

    def _lonlat_at(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """Lon/lat (degrees) at fractional pixel coordinates; NaN where there is none."""
        px, py = self.pixel_xy(x, y)
        px, py = np.broadcast_arrays(px, py)
        lon, lat = self.transformer.transform(np.ravel(px), np.ravel(py), errcheck=False)
        lon = np.asarray(lon, dtype=np.float64).reshape(px.shape)
        lat = np.asarray(lat, dtype=np.float64).reshape(px.shape)
        bad = ~(np.isfinite(lon) & np.isfinite(lat) & (np.abs(lat) <= 90.0))
        if bad.any():
            lon = np.where(bad, np.nan, lon)
            lat = np.where(bad, np.nan, lat)
        return lon, lat

    def pixel_lonlat(self, i, j):
        """Centre (lon, lat) in degrees of pixel column ``i``, row ``j`` (pyproj's
        inverse; NaN outside the projection's domain)."""
        lon, lat = self._lonlat_at(
            np.asarray(i, dtype=np.float64) + 0.5, np.asarray(j, dtype=np.float64) + 0.5
        )
        if np.ndim(lon) == 0:
            return float(lon), float(lat)
        return lon, lat

    def _points(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """Unit vectors at fractional pixel coordinates and whether each has an inverse."""
        lon, lat = self._lonlat_at(x, y)
        ok = np.isfinite(lon)
        v = lonlat_to_xyz(np.where(ok, lon, 0.0), np.where(ok, lat, 0.0))
        return v, ok

    def _check_domain(self) -> None:
        """Refuse bounds that miss the CRS's area of use (projected) altogether, or where
        no point of a 9 x 9 sample (corners and edges included) has an inverse that
        projects back to it."""
        area = None
        if self._crs.area_of_use is not None:
            try:
                area = self.area_bounds(self._crs)
            except InvalidGridError:
                area = None
        xmin, ymin, xmax, ymax = self.bounds
        if area is not None and (
            xmax <= area[0] or xmin >= area[2] or ymax <= area[1] or ymin >= area[3]
        ):
            raise InvalidGridError(
                f"bounds {self.bounds!r} lie outside the domain of {self._crs.name!r}: its "
                f"area of use is {tuple(round(v) for v in area)!r} in its units"
            )
        t = np.linspace(0.0, 1.0, 9)
        x, y = np.meshgrid(t * self.width, t * self.height)
        lon, lat = self._lonlat_at(x, y)
        ok = np.isfinite(lon)
        if ok.any():
            fwd = _forward_transformer(self._crs)
            bx, by = fwd.transform(lon[ok], lat[ok], errcheck=False)
            px, py = self.pixel_xy(x[ok], y[ok])
            xmin, ymin, xmax, ymax = self.bounds
            tol = 1e-6 * max(xmax - xmin, ymax - ymin, 1.0)
            ok[ok] = (np.abs(np.asarray(bx) - px) <= tol) & (np.abs(np.asarray(by) - py) <= tol)
        if not ok.any():
            raise InvalidGridError(
                f"bounds {self.bounds!r} lie outside the domain of {self._crs.name!r}: "
                "no point of them has a longitude and latitude"
            )

    # ------------------------------------------------------------------ levels
    def _lipschitz(self) -> float | None:
        """Radians on the unit sphere per CRS unit, an upper bound (formula grids), or None."""
        if "_lip" in self.__dict__:
            return self.__dict__["_lip"]
        # every cell of every level (with the segments from its centre to its pixels)
        # lies in the blocks of level 0 that hold the grid's pixels
        rows, cols = self.level_shape(0)
        b = self.block(0)
        (xa, xb), (ya, yb) = self.pixel_xy(np.array([0.0, cols * b]), np.array([0.0, rows * b]))
        box = (float(xa), float(yb), float(xb), float(ya))
        k = polar_scale_min(self._crs)
        if k is None:
            k = transverse_scale_min(self._crs, box)
        lip = None
        if k is not None and k > 0.0:
            a = self._crs.ellipsoid.semi_major_metre
            es = eccentricity_squared(self._crs)
            unit = self._crs.axis_info[0].unit_conversion_factor or 1.0
            # rounded up by a relative 1e-9 (the scale formula's and the constants' roundings)
            lip = unit / (k * a * (1.0 - es)) * (1.0 + 1e-9)
        if lip is None:  # LAEA, the conics (gloffset.grids.stretch)
            lip = inverse_lipschitz(self._crs, box)
        self.__dict__["_lip"] = lip
        return lip

    def _takes_glsl(self) -> bool:
        """Whether the GPU levels may compute this grid's centres in GLSL: polar
        stereographic grids; LAEA grids whose cell centres keep clear of the poles and
        the antipode (:func:`~gloffset.grids.laea.laea_clear`); transverse Mercator grids
        with the formula bound (its slack covers the function) within the function's
        range (:func:`~gloffset.grids.transverse.tm_clear`); Lambert conformal conic grids
        likewise (:func:`~gloffset.grids.conic.lcc_clear`)."""
        if polar_params(self._crs) is not None:
            return True
        if laea_params(self._crs) is not None:
            return laea_clear(self._crs, self._centre_box())
        if tm_params(self._crs) is not None:
            return self._lipschitz() is not None and tm_clear(self._crs, self._centre_box())
        if lcc_params(self._crs) is not None:
            return self._lipschitz() is not None and lcc_clear(self._crs, self._centre_box())
        return False

    def _centre_box(self) -> tuple[float, float, float, float]:
        """The box (CRS units) of every level's cell centres (blocks at the east and south
        edges reach past the grid)."""
        fx, fy = [0.5], [0.5]
        for lev in range(self.n_levels):
            b = self.block(lev)
            h, w = self.level_shape(lev)
            fx.append((w - 0.5) * b)
            fy.append((h - 0.5) * b)
        x, y = self.pixel_xy(np.array([0.5, max(fx)]), np.array([0.5, max(fy)]))
        return (float(x.min()), float(y.min()), float(x.max()), float(y.max()))

    def _glsl_slack(self, level: int) -> float:
        """What the bounds made from pyproj's pixel centres gain for a GLSL function's
        centres (LAEA grids): each of a cell's and its child's centres moves by at most
        :data:`~gloffset.grids.laea.LAEA_PYPROJ_BOUND`, so twice that a level."""
        if self.centres != "glsl":
            return 0.0
        return 2.0 * LAEA_PYPROJ_BOUND * (self.n_levels - 1 - level)

    def _half_diagonal(self, level: int) -> float:
        xmin, ymin, xmax, ymax = self._frame[4]
        fw, fh = self._frame[2], self._frame[3]
        b = self.block(level)
        return 0.5 * b * math.hypot((xmax - xmin) / fw, (ymax - ymin) / fh) * (1.0 + 1e-12)

    def _raw_centres(self, level: int, j, i) -> tuple[np.ndarray, np.ndarray]:
        b = self.block(level)
        return self._points(
            (np.asarray(i, dtype=np.float64) + 0.5) * b, (np.asarray(j, dtype=np.float64) + 0.5) * b
        )

    def centers(self, level: int, j, i) -> np.ndarray:
        """Unit vectors of the centres of cells (row ``j``, column ``i``) of ``level``:
        pyproj's inverse of the block's centre (see the module notes for cells without
        one; the pixels outside the domain are masked afterwards)."""
        j, i = np.broadcast_arrays(np.asarray(j, dtype=np.int64), np.asarray(i, dtype=np.int64))
        if level < self.n_levels - 1 and self._twin() is not None:
            return self.texture_centers(level, j, i)
        v, ok = self._raw_centres(level, j, i)
        if ok.all() or self._lipschitz() is not None or level == self.n_levels - 1:
            return v
        sub = self._tree()["centres"][level]
        h, w = sub.shape[:2]
        jj, ii = np.minimum(j, h - 1), np.minimum(i, w - 1)
        return np.where(ok[..., None], v, sub[jj, ii])

    def _twin(self):
        """The float64 twin of the inverse (:func:`polar_inverse`), or None."""
        if "_inverse" not in self.__dict__:
            self.__dict__["_inverse"] = polar_inverse(self._crs)
        return self.__dict__["_inverse"]

    def texture_centers(self, level: int, j, i) -> np.ndarray:
        """The centres the GPU levels read (:mod:`gloffset.raster.layout`): the float64
        twin's where the projection has one (within 1e-12 rad of :meth:`centers`; the
        coarse levels' centres are the twin's anyway), else :meth:`centers`."""
        inv = self._twin()
        if inv is None:
            return self.centers(level, j, i)
        b = self.block(level)
        x = (np.asarray(i, dtype=np.float64) + 0.5) * b
        y = (np.asarray(j, dtype=np.float64) + 0.5) * b
        return inv(*self.pixel_xy(x, y))

    def glsl_centres(self) -> GlslCentres:
        """The cell centres as a GLSL function (``centres == "glsl"``). Polar
        stereographic CRSs (:func:`polar_glsl`): within 4e-15 rad of the exact inverse
        (9e-16 measured), 1e-12 of pyproj's (7e-13 measured: PROJ's iteration stops at
        steps of 1e-10 rad), and 1e-13 of the float64 twin (tested at many pixels).
        LAEA CRSs (:func:`~gloffset.grids.laea.laea_glsl`, grids that
        :func:`~gloffset.grids.laea.laea_clear` admits): pyproj's inverse, within
        :data:`~gloffset.grids.laea.LAEA_PYPROJ_BOUND` (1e-12 rad) of pyproj's.
        Transverse Mercator CRSs (:func:`~gloffset.grids.transverse.tm_glsl`, grids with
        the formula bound): pyproj's inverse, within 1e-12 rad of pyproj's (4e-15
        measured), covered by the bound's 3e-9 rad a level. Lambert conformal conic CRSs
        (:func:`~gloffset.grids.conic.lcc_glsl`, grids with the formula bound that
        :func:`~gloffset.grids.conic.lcc_clear` admits): pyproj's inverse, within 1e-12
        rad of pyproj's, covered by the same slack."""
        got = (
            polar_glsl(self._crs, self._frame)
            or laea_glsl(self._crs, self._frame)
            or tm_glsl(self._crs, self._frame)
            or lcc_glsl(self._crs, self._frame)
        )
        if got is None:
            raise InvalidGridError(f"{self._crs.name!r} has no GLSL centres")
        return got

    def _tree(self) -> dict:
        """The bounds made from every pixel centre (see the module notes): per level the
        cells' rho, their centres (a child's where their own has no inverse) and whether
        a pixel of theirs is in the domain."""
        tree = self.__dict__.get("_tree_cache")
        if tree is not None:
            return tree
        n = self.n_levels
        last = n - 1
        H, W = self.level_shape(last)
        if n == 1:
            _, ok = self._raw_centres(last, *np.meshgrid(np.arange(H), np.arange(W), indexing="ij"))
            tree = {"rho": [np.zeros((H, W))], "centres": [None], "valid": [ok]}
            self.__dict__["_tree_cache"] = tree
            return tree
        rho: list = [None] * n
        cen: list = [None] * n
        valid: list = [None] * n
        rho[last] = None  # 0 everywhere (pixels are decided at their centres)
        valid[last] = np.zeros((H, W), dtype=bool)
        # the level above the pixels, from strips of pixel rows
        h1, w1 = self.level_shape(last - 1)
        r1 = np.zeros((h1, w1))
        c1 = np.zeros((h1, w1, 3))
        v1 = np.zeros((h1, w1), dtype=bool)
        ii = np.arange(W)
        for y0 in range(0, H, _STRIP):
            rows = np.arange(y0, min(H, y0 + _STRIP))
            jj, iii = np.meshgrid(rows, ii, indexing="ij")
            p, ok = self._raw_centres(last, jj, iii)
            valid[last][rows] = ok
            prow = rows // 2
            pj = np.arange(prow[0], prow[-1] + 1)
            cj, ci = np.meshgrid(pj, np.arange(w1), indexing="ij")
            c, cok = self._raw_centres(last - 1, cj, ci)
            self._fill(c, cok, r1, c1, v1, pj, p, ok, rows - 2 * pj[0], None)
        rho[last - 1], cen[last - 1], valid[last - 1] = pad(r1), c1, v1
        for lev in range(last - 2, -1, -1):
            h, w = self.level_shape(lev)
            cj, ci = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
            c, cok = self._raw_centres(lev, cj, ci)
            r = np.zeros((h, w))
            cc = np.zeros((h, w, 3))
            vv = np.zeros((h, w), dtype=bool)
            self._fill(
                c,
                cok,
                r,
                cc,
                vv,
                np.arange(h),
                cen[lev + 1],
                valid[lev + 1],
                np.arange(len(cen[lev + 1])),
                rho[lev + 1],
            )
            rho[lev], cen[lev], valid[lev] = pad(r), cc, vv
        tree = {"rho": rho, "centres": cen, "valid": valid}
        self.__dict__["_tree_cache"] = tree
        return tree

    @staticmethod
    def _fill(c, cok, r, cc, vv, prows, child, child_ok, child_rows, child_rho) -> None:
        """Bounds and centres of parent rows ``prows`` from their children (rows
        ``child_rows`` of the arrays ``child``, ``child_ok``, ``child_rho``; parent row of
        a child row ``k``: ``prows[0] + k // 2`` where ``child_rows`` start at 0)."""
        h = len(prows)
        w = r.shape[1]
        cw = child.shape[1]
        cent = c.copy()
        have = cok.copy()
        # a parent without an inverse takes its first child's centre that has one
        for dj in (0, 1):
            for di in (0, 1):
                k = 2 * np.arange(h)[:, None] + dj
                q = 2 * np.arange(w)[None, :] + di
                inside = (k < len(child_rows)) & (q < cw)
                kk, qq = np.minimum(k, len(child_rows) - 1), np.minimum(q, cw - 1)
                kk = np.broadcast_to(kk, (h, w))
                qq = np.broadcast_to(qq, (h, w))
                okc = inside & child_ok[kk, qq]
                take = ~have & okc
                cent[take] = child[kk, qq][take]
                have |= take
        out = np.zeros((h, w))
        anyv = np.zeros((h, w), dtype=bool)
        for dj in (0, 1):
            for di in (0, 1):
                k = 2 * np.arange(h)[:, None] + dj
                q = 2 * np.arange(w)[None, :] + di
                inside = (k < len(child_rows)) & (q < cw)
                kk = np.broadcast_to(np.minimum(k, len(child_rows) - 1), (h, w))
                qq = np.broadcast_to(np.minimum(q, cw - 1), (h, w))
                okc = inside & child_ok[kk, qq]
                a = angle(cent, child[kk, qq])
                if child_rho is not None:
                    a = a + child_rho[kk, qq]
                out = np.where(okc, np.maximum(out, a), out)
                anyv |= okc
        r[prows] = out
        cc[prows] = np.where(have[..., None], cent, np.array([0.0, 0.0, 1.0]))
        vv[prows] = anyv

    def rho_at(self, level: int, j, i) -> np.ndarray:
        """The bound of cells (``j``, ``i``) of ``level`` (0 at the output level)."""
        j, i = np.broadcast_arrays(np.asarray(j, dtype=np.int64), np.asarray(i, dtype=np.int64))
        last = self.n_levels - 1
        if level == last:
            return np.zeros(j.shape)
        lip = self._lipschitz()
        if lip is not None:
            r = lip * self._half_diagonal(level) + _LEVEL_SLACK * (last - level)
            return np.full(j.shape, r)
        r = self._tree()["rho"][level]
        h, w = r.shape
        return r[np.minimum(j, h - 1), np.minimum(i, w - 1)] + self._glsl_slack(level)

    def rho(self, level: int) -> np.ndarray:
        """Per row of ``level``: the largest bound of its cells."""
        h, w = self.level_shape(level)
        if level == self.n_levels - 1:
            return np.zeros(h)
        if self._lipschitz() is not None:
            return self.rho_at(level, np.arange(h), 0)
        return self._tree()["rho"][level].max(axis=1) + self._glsl_slack(level)

    def area_rho_at(self, level: int, j, i) -> np.ndarray:
        """A bound on the distance from the centres of cells (``j``, ``i``) to their
        points (at the output level, the pixel's own extent): the formula's where there
        is one, else the next level's bound of the cell (a pixel: its 2 x 2 parent's)."""
        j, i = np.broadcast_arrays(np.asarray(j, dtype=np.int64), np.asarray(i, dtype=np.int64))
        lip = self._lipschitz()
        if lip is not None:
            return np.full(j.shape, pad(lip * self._half_diagonal(level)))
        if level == self.n_levels - 1:
            if level == 0:
                return np.zeros(j.shape)
            return 2.0 * self.rho_at(level - 1, j // 2, i // 2)
        return self.rho_at(level, j, i)

    def valid(self, level: int) -> np.ndarray | None:
        """Per cell of ``level``: whether a pixel of it is in the projection's domain;
        None when every pixel is (formula grids, and grids whose pixels all are)."""
        if self._lipschitz() is not None:
            return None
        tree = self._tree()
        if tree["valid"][-1].all():
            return None
        return tree["valid"][level]

    def subgrid(self, x0: int, y0: int, w: int, h: int) -> Projected:
        """The pixels ``[x0, x0+w) x [y0, y0+h)`` as a grid of their own (the same pixel
        centres, bit for bit)."""
        out = object.__new__(Projected)
        out._crs = self._crs
        out.width, out.height = int(w), int(h)
        fx0, fy0, fw, fh, full = self._frame
        xmin, ymin, xmax, ymax = full
        out._frame = (fx0 + x0, fy0 + y0, fw, fh, full)
        if "centres" in self.__dict__:
            out.centres = self.centres
        out.bounds = (
            xmin + (fx0 + x0) * (xmax - xmin) / fw,
            ymax - (fy0 + y0 + h) * (ymax - ymin) / fh,
            xmin + (fx0 + x0 + w) * (xmax - xmin) / fw,
            ymax - (fy0 + y0) * (ymax - ymin) / fh,
        )
        # a part's coarse cells reach past its own east and south edges
        if out.centres == "glsl" and not out._takes_glsl():
            out.centres = "texture"
        return out
