"""Exceptions raised by gloffset.

Every error that gloffset raises on bad input derives from :class:`GloffsetError`
and from the builtin exception a Python user would expect (``ValueError`` for bad
values, ``OSError`` for files), so ``except ValueError`` keeps working.
"""

from __future__ import annotations


class GloffsetError(Exception):
    """Base class of every error raised by gloffset."""


class InvalidGeometryError(GloffsetError, ValueError):
    """The input geometry cannot be used (NaN, latitude out of range, too few points...).

    The message names the feature, part and vertex where the problem was found.
    """


class InvalidDistanceError(GloffsetError, ValueError):
    """A distance is not a finite number, has an unknown unit, or is out of range."""


class InputFormatError(GloffsetError, ValueError):
    """A file or object is not GeoJSON (or another supported input) that gloffset can read."""


class InvalidLevelError(GloffsetError, ValueError):
    """A multiresolution level is not an integer in the range a decomposition has."""


class OptionError(GloffsetError, ValueError):
    """An option (a keyword argument, or a command-line option) has a value gloffset cannot use."""


class OutputError(GloffsetError, OSError):
    """An output cannot be written (missing folder, no permission, disk full, unsupported
    format...). The message names the target; a file that was there is left as it was."""


class GLContextError(GloffsetError, RuntimeError):
    """No OpenGL context could be created, or the context lacks a needed capability."""
