"""The keyword options of the public raster functions, gathered into one frozen dataclass
per function (:class:`~gloffset.tiles.tiling.job.PyramidOptions`,
:class:`~gloffset.raster.rasterized.offset.RasterOffsetOptions`): the public function
takes them as keywords, the package passes the object on.
"""

from __future__ import annotations

from dataclasses import fields
from typing import Any, TypeVar

__all__ = ["check_keywords", "keyword_options", "option_names"]

T = TypeVar("T")


def option_names(cls) -> list[str]:
    """The fields of the options dataclass ``cls``, in declaration order."""
    return [f.name for f in fields(cls)]


def check_keywords(what: str, options, valid) -> None:
    """Refuse a keyword of ``options`` not in ``valid`` with a :class:`TypeError` that
    names it and lists ``valid``, as Python names an unknown keyword of ``what()``."""
    unknown = [k for k in options if k not in valid]
    if unknown:
        raise TypeError(
            f"{what}() got an unexpected keyword argument {unknown[0]!r}; its options are "
            + ", ".join(valid)
        )


def keyword_options(cls: type[T], options: dict[str, Any], what: str) -> T:
    """``cls(**options)``, a keyword that is no field of ``cls`` refused
    (:func:`check_keywords`)."""
    check_keywords(what, options, option_names(cls))
    return cls(**options)
