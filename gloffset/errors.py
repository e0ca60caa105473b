"""Exceptions raised by gloffset: one hierarchy, one class per concept.

Every error that gloffset raises derives from :class:`GloffsetError` and from the builtin
exception a Python user would expect (``ValueError`` for bad values, ``OSError`` for files,
``RuntimeError`` for OpenGL failures), so ``except ValueError`` keeps working. Every class
is exported from :mod:`gloffset`; the command line prints any of them as one line
(``gloffset: error: ...``) with exit status 2.

::

    GloffsetError
    |-- InvalidGeometryError   (ValueError)
    |-- InvalidDistanceError   (ValueError)
    |-- InputFormatError       (ValueError)
    |-- InvalidLevelError      (ValueError)
    |-- OptionError            (ValueError)
    |   |-- InvalidMaskError
    |   '-- InvalidEllipsoidError
    |-- InvalidGridError       (ValueError)
    |   '-- TilesError
    |-- OutputError            (OSError)
    |   '-- OutputExistsError  (FileExistsError)
    |-- GLContextError         (RuntimeError)
    '-- ShaderError            (RuntimeError)

Former names stay importable where they were defined, as aliases of these classes: the
list is on the design page (``docs/design.md``, *Module notes*).
"""

from __future__ import annotations

__all__ = [
    "GLContextError",
    "GloffsetError",
    "InputFormatError",
    "InvalidDistanceError",
    "InvalidEllipsoidError",
    "InvalidGeometryError",
    "InvalidGridError",
    "InvalidLevelError",
    "InvalidMaskError",
    "OptionError",
    "OutputError",
    "OutputExistsError",
    "QueueFullError",
    "ShaderError",
    "TilesError",
]


class GloffsetError(Exception):
    """Base class of every error raised by gloffset (never raised itself).

    ``except GloffsetError`` catches every error gloffset raises on bad input, bad
    options, unwritable outputs and OpenGL failures.
    """


# ------------------------------------------------------------------------------ bad values
class InvalidGeometryError(GloffsetError, ValueError):
    """The input geometry cannot be used (NaN, latitude out of range, too few points...).

    Raised when a :class:`~gloffset.Shape` is built or read, and by functions taking
    points. The message names the feature, part and vertex where the problem was found.
    """


class InvalidDistanceError(GloffsetError, ValueError):
    """A distance is not a finite number, has an unknown unit, or is out of range.

    Raised by :func:`~gloffset.parse_distance` and by every function taking a distance
    (an offset of a quarter circle or more, an inward offset of curves with no polygon...).
    """


class InputFormatError(GloffsetError, ValueError):
    """A file or object is not input that gloffset can read.

    Raised on a missing or unreadable file, malformed JSON or GeoJSON, an object gloffset
    does not know how to read, a lon/lat array of the wrong shape, a points CSV without
    lon and lat columns, a mask image that is neither grey nor transparent, and a set of
    cube-face mask images that are missing, not square or of different sizes.
    """


class InvalidLevelError(GloffsetError, ValueError):
    """A multiresolution level is not an integer in the range a decomposition has.

    Raised by :func:`~gloffset.decompose` and :class:`~gloffset.Decomposition` (a level or
    a number of levels) and by :class:`~gloffset.Index` (a level or a tree depth).
    """


class OptionError(GloffsetError, ValueError):
    """An option (a keyword argument, or a command-line option) has a value gloffset cannot use.

    Raised by :func:`~gloffset.render` and :func:`~gloffset.raster_offset` (an unknown
    ``out``, ``backend`` or ``mode``, a level out of range, an unsupported grid, an image
    too large), by tile styles (opacity, outline width, a colour that cannot be parsed)
    and by the command line (a malformed ``--size`` or ``--bounds``, options that do not
    go together).
    """


class InvalidMaskError(OptionError):
    """A curve mask given to :func:`~gloffset.raster_offset` is not one.

    It has the wrong shape or dtype, or has no curve cell.
    """


class InvalidEllipsoidError(OptionError):
    """An ``ellipsoid=`` option (``--ellipsoid`` on the command line) is not an ellipsoid.

    It is not a known name (``"WGS84"``, ``"GRS80"``), an ``(a, f)`` pair with a positive
    finite semi-major axis ``a`` in metres and a flattening ``f`` in [0, 1/50], or an
    :class:`~gloffset.Ellipsoid`.

    Raised by :func:`~gloffset.distance`, :func:`~gloffset.contains` and
    :class:`~gloffset.Ellipsoid` itself.
    """


class InvalidGridError(GloffsetError, ValueError):
    """A grid has a bad size, bounds or index.

    Raised when a grid of :mod:`gloffset.grids` is made (size not a positive integer,
    bounds with S >= N, a zoom beyond 22, a tile size that is not a power of two) and
    by cell and tile look-ups out of range.
    """


class TilesError(InvalidGridError):
    """A tile pyramid request has a bad zoom range, tile size or option.

    The limits are those of :mod:`gloffset.grids.mercator`.

    Raised by :func:`gloffset.tiles.pyramid` and ``gloffset tiles``.
    """


# ------------------------------------------------------------------------------- files
class OutputError(GloffsetError, OSError):
    """An output cannot be written.

    A missing folder, no permission, a full disk, an unsupported format, a tile store that
    gloffset did not write...

    The message names the target; a file that was there is left as it was.
    """


class OutputExistsError(OutputError, FileExistsError):
    """The output of a tile pyramid exists and neither resume nor overwrite was asked for.

    (``--resume`` / ``--force`` on the command line).
    """

    def __init__(self, path):
        super().__init__(
            f"{str(path)!r} exists; use --resume to complete it or --force to replace it"
        )


# ------------------------------------------------------------------------------- OpenGL
class GLContextError(GloffsetError, RuntimeError):
    """No OpenGL context, or one that lacks what a render needs.

    No context could be created, or the context lacks a needed capability or buffer size
    for a render (raised by the ``gpu`` backend; the ``cpu`` backend needs no context).
    """


class ShaderError(GloffsetError, RuntimeError):
    """A shader source in ``shaders/`` is missing or malformed, or does not compile or link.

    (the message points at the file and line).
    """


# ------------------------------------------------------------------------------- serving
class QueueFullError(GloffsetError, RuntimeError):
    """The tile server's render queue holds as many tiles as it may: try again later.

    ``gloffset serve`` answers 503 with ``Retry-After``.
    """
