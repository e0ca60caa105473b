"""Many distances of one shape on one grid: ``render_many(shape, distances, grid)``.

The region at each distance is the mask :func:`gloffset.render` gives, byte for byte:
each distance is rendered by it. What the distances share is everything that does not
depend on the distance: the input read and checked once, the caches a
:class:`~gloffset.Shape` keeps (its arcs and their cap tree, the inside test's
:class:`~gloffset.Index`, the multiresolution decomposition and the curves simplified to a
fraction of a pixel, :mod:`gloffset.raster.simplified`, whose tolerance depends on the
grid's pixels only), and the GL context. :func:`mask_bands` folds the masks into one
image: the index of the smallest distance whose region holds each pixel.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidDistanceError
from ..shape import read
from ..units import EARTH_RADIUS, RASTER_LIMIT, offset_angle, to_metres
from .render import render, render_angle

__all__ = ["render_many", "mask_bands", "MAX_DISTANCES"]

#: The most distances of one call (a band image is uint8, 0 for "none").
MAX_DISTANCES = 255


def _given(distance) -> str:
    return distance.strip() if isinstance(distance, str) else repr(distance)


def check_distances(shape, distances, radius: float) -> list[float]:
    """Return the distances as angles on the sphere of ``radius`` (in the order given).

    Refused with :class:`~gloffset.errors.InvalidDistanceError` when there are none, more
    than :data:`MAX_DISTANCES`, one a render refuses, or two equal ones (named as given).
    """
    if isinstance(distances, (str, bytes, int, float)) or distances is None:
        raise InvalidDistanceError(
            f"distances must be a list of distances, got {distances!r} (for one distance "
            "use gloffset.render)"
        )
    distances = list(distances)
    if not distances:
        raise InvalidDistanceError("distances is empty: give at least one distance")
    if len(distances) > MAX_DISTANCES:
        raise InvalidDistanceError(
            f"{len(distances)} distances given, at most {MAX_DISTANCES} at once"
        )
    angles: list[float] = []
    seen: dict[float, object] = {}
    for dist in distances:
        a = offset_angle(shape, dist, radius, limit=RASTER_LIMIT, what="render")
        if a in seen:
            raise InvalidDistanceError(
                f"distance {_given(dist)} is given twice (as {_given(seen[a])} before): "
                "each distance once"
            )
        seen[a] = dist
        angles.append(a)
    return angles


def render_many(
    shape,
    distances,
    grid,
    *,
    radius: float = EARTH_RADIUS,
    backend: str = "gpu",
    tile: int | None = None,
    ellipsoid=None,
) -> list[np.ndarray]:
    """Return the masks of the offset regions of ``shape`` at several distances.

    Parameters
    ----------
    shape : Shape or anything :func:`gloffset.read` accepts
        Read once for all the distances.
    distances : sequence of float or str
        In the units of ``radius`` (metres by default), or strings with a unit
        (``"127km"``); negative shrinks polygons. Each distance once, at most
        :data:`MAX_DISTANCES`.
    grid, backend, tile, ellipsoid
        As for :func:`gloffset.render` (with ``ellipsoid``, lengths in metres).

    Returns
    -------
    list of numpy.ndarray
        One uint8 mask per distance, in the order given, each byte-identical to
        ``gloffset.render(shape, distance, grid, ...)`` (same accuracy contract: the
        float64 reference's pixels but within 1e-3 of a pixel of the distance or of a
        seam).

    Raises
    ------
    InvalidDistanceError
        No distance, too many, a duplicate, or one that ``render`` refuses; checked
        before any work.

    Notes
    -----
    The work is that of the single renders less what they share (the input, the
    shape's caches, the GL context): ``benchmarks/many_distances.py`` measures it.
    """
    shape = read(shape)
    if ellipsoid is None:  # the angles converted once, each rendered at its angle
        angles = check_distances(shape, distances, radius)
        return [render_angle(shape, a, grid, backend=backend, tile=tile) for a in angles]
    else:  # geodesic lengths in metres, the render's limits on the sphere of radius a
        from ..ellipsoid import as_ellipsoid

        distances = [to_metres(d) for d in distances]
        ell = as_ellipsoid(ellipsoid)
        assert ell is not None  # ellipsoid is not None
        check_distances(shape, distances, ell.a)
    return [
        render(shape, dist, grid, backend=backend, tile=tile, ellipsoid=ellipsoid)
        for dist in distances
    ]


def mask_bands(masks, distances) -> tuple[np.ndarray, list[int]]:
    """Return one uint8 image of several masks.

    At each pixel, ``k`` (1-based) when the ``k``-th smallest distance is the smallest
    whose mask holds the pixel, 0 when none does.

    Parameters
    ----------
    masks : sequence of numpy.ndarray
        Masks of one shape (non-zero inside), as :func:`render_many` gives them.
    distances : sequence of float
        Their distances (angles or lengths: only their order counts), each once.

    Returns
    -------
    bands : numpy.ndarray
        uint8, the masks' shape.
    order : list of int
        The masks' indices from the smallest distance to the largest: band ``k`` is
        ``distances[order[k - 1]]``.
    """
    if len(masks) != len(distances) or not masks:
        raise InvalidDistanceError(
            f"mask_bands needs one distance per mask, got {len(masks)} masks and "
            f"{len(distances)} distances"
        )
    if len(masks) > MAX_DISTANCES:
        raise InvalidDistanceError(f"{len(masks)} masks, at most {MAX_DISTANCES} bands")
    order = sorted(range(len(distances)), key=lambda k: distances[k])
    bands = np.zeros(np.shape(masks[0]), dtype=np.uint8)
    for band, k in reversed(list(enumerate(order, start=1))):
        bands[np.asarray(masks[k]) != 0] = band  # the smallest distance is written last
    return bands, order
