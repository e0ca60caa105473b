"""Values built once and kept, safe to share between threads.

The tile server (``gloffset serve``) calls the library from its render thread, its field
thread and a pool of worker threads at once, on the same shapes. What a shape, a grid or
an index builds lazily and keeps is built here, by one mechanism:

- a kept value is read without a lock (one dict or attribute read: the hot path);
- a value not built yet is built under a lock of its own (one per object and name, or
  per key of a :class:`Memo`), the read repeated under it (double-checked), so each
  builder runs once however many threads ask at the same time, and a value is seen
  only once it is complete;
- builds of different values do not wait for each other (a lock per value, not per
  object), and a build that needs another value takes that value's lock: threads can
  wait on each other only along the builds' own dependencies, which have no cycle
  (a cycle would recurse for ever in one thread too). The locks are re-entrant and
  exist only while a build runs;
- a kept value is never changed in place: a new value replaces it (a deeper index), an
  evicted one is dropped (a bounded :class:`Memo`), and a thread still holding the old
  one keeps a complete, valid object. Its numpy arrays are made read-only when it is
  kept (:func:`freeze`), so a write into one raises instead of changing what every
  thread reads.

Builders must be pure (the same inputs, the same value): a value evicted and built
again is the same, and a builder that raises keeps nothing (the next call builds again).
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Hashable, Iterator, Mapping
from typing import Any, Generic, TypeVar

import numpy as np

__all__ = ["Memo", "Locks", "MISSING", "freeze", "kept_property", "once_attr"]

T = TypeVar("T")
#: what a check of :meth:`Locks.run` answers for "not built"
MISSING: Any = object()


def freeze(value: T) -> T:
    """``value``, its numpy arrays made read-only: the value itself, the items of a tuple
    or list, and the attributes of an object (and the items of its tuples), one level
    down. What a kept object makes later (its own lazy parts) is frozen where it is kept."""

    def one(v) -> None:
        if isinstance(v, np.ndarray):
            v.setflags(write=False)
        elif isinstance(v, (tuple, list)):
            for x in v:
                if isinstance(x, np.ndarray):
                    x.setflags(write=False)

    one(value)
    for v in getattr(value, "__dict__", {}).values():
        one(v)
    return value


class Locks:
    """A re-entrant lock per key, made when a build of the key starts and dropped when the
    last build of it ends (so a long-lived object with many keys keeps no locks)."""

    __slots__ = ("_guard", "_locks")

    def __init__(self) -> None:
        self._guard = threading.Lock()
        self._locks: dict = {}  # key -> [RLock, number of threads using it]

    def run(self, key: Hashable, check: Callable[[], Any], build: Callable[[], T]) -> T:
        """``check()`` under the lock of ``key``, and ``build()`` when it answered
        :data:`MISSING`; the first's value or the second's."""
        with self._guard:
            entry = self._locks.get(key)
            if entry is None:
                entry = self._locks[key] = [threading.RLock(), 0]
            entry[1] += 1
        try:
            with entry[0]:
                got = check()
                return build() if got is MISSING else got
        finally:
            with self._guard:
                entry[1] -= 1
                if entry[1] == 0:
                    del self._locks[key]

    def __len__(self) -> int:
        """The keys being built now."""
        return len(self._locks)


class Memo(Mapping, Generic[T]):
    """Values by key, each built once (:meth:`once`) and kept; a read-only mapping.

    Reads take no lock.
    """

    __slots__ = ("_values", "_locks", "_guard")

    def __init__(self) -> None:
        self._values: dict = {}
        self._locks = Locks()
        self._guard = threading.Lock()  # changes of _values (reads need none)

    def once(
        self,
        key: Hashable,
        build: Callable[[], T],
        fresh: Callable[[T], bool] | None = None,
        keep: int | None = None,
    ) -> T:
        """The value of ``key``, built by ``build()`` when not kept (or when ``fresh`` says
        the kept one will not do), once however many threads ask at the same time.

        ``keep`` bounds the number of values kept once this one is: the oldest built go
        first (values asked for again are not moved; a rebuilt one is the newest)."""
        got = self._values.get(key, MISSING)
        if got is not MISSING and (fresh is None or fresh(got)):
            return got

        def check():
            got = self._values.get(key, MISSING)
            return got if got is not MISSING and (fresh is None or fresh(got)) else MISSING

        def make():
            value = freeze(build())
            with self._guard:
                self._values.pop(key, None)  # a rebuilt value is the newest
                if keep is not None:
                    while self._values and len(self._values) >= keep:
                        del self._values[next(iter(self._values))]
                self._values[key] = value
            return value

        return self._locks.run(key, check, make)

    def clear(self) -> None:
        """Forget every value (threads holding one keep it)."""
        with self._guard:
            self._values.clear()

    def __getitem__(self, key: Hashable) -> T:
        return self._values[key]

    def __contains__(self, key: object) -> bool:
        return key in self._values

    def __iter__(self) -> Iterator:
        with self._guard:
            return iter(list(self._values))

    def __len__(self) -> int:
        return len(self._values)

    def __repr__(self) -> str:
        return f"Memo({len(self)} kept)"


#: the locks of :func:`once_attr` and :class:`kept_property`, by (object id, name): an
#: object's id is unique while it lives, and a lock lives only while a build runs
_ATTR_LOCKS = Locks()


def once_attr(obj: Any, name: str, build: Callable[[], T]) -> T:
    """``obj.<name>`` (in its ``__dict__``), built by ``build()`` and set once when absent or
    None, under a lock of the object's and name's (frozen dataclasses too)."""
    got = obj.__dict__.get(name)
    if got is not None:
        return got

    def check():
        got = obj.__dict__.get(name)
        return MISSING if got is None else got

    def make():
        value = freeze(build())
        object.__setattr__(obj, name, value)
        return value

    return _ATTR_LOCKS.run((id(obj), name), check, make)


class kept_property(Generic[T]):  # noqa: N801 - used as a decorator, like cached_property
    """:func:`functools.cached_property` built under a lock of the object's and name's
    (:func:`once_attr`): the getter runs once per object however many threads ask, and
    reads of a built value go straight to the object's ``__dict__``."""

    def __init__(self, func: Callable[[Any], T]) -> None:
        self.func = func
        self.name = func.__name__
        self.__doc__ = func.__doc__

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, obj: Any, owner: type | None = None) -> Any:
        if obj is None:
            return self
        return once_attr(obj, self.name, lambda: self.func(obj))
