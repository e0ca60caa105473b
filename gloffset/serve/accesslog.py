"""The access log of ``gloffset serve`` (``--access-log FILE|-``, off by default): one line
per request, written when its response ends::

    2026-11-26T23:44:06.123Z GET /tiles/mexico/127km/5/6/13.png 200 1843 4.7

the time (UTC, milliseconds) the request arrived, the method, the path with its query, the
status, the bytes of the body sent and the milliseconds from the request to the end of the
response. A request whose client went away before an answer is logged with status 499, one
that failed with status 500.
"""

from __future__ import annotations

import sys
import time
from datetime import datetime, timezone
from pathlib import Path

from ..errors import OutputError

__all__ = ["AccessLog", "open_log"]


def open_log(target: str):
    """The stream of ``target``: standard output for ``-``, else the file, appended to
    and flushed line by line (several server processes may share it: each line is one
    write of an append-mode file)."""
    if target == "-":
        return sys.stdout
    try:
        return open(Path(target), "a", buffering=1, encoding="utf-8")  # noqa: SIM115
    except OSError as exc:
        raise OutputError(f"cannot open the access log {target!r}: {exc}") from None


class AccessLog:
    """ASGI middleware: the application ``app`` with every HTTP request logged to
    ``stream`` (a text stream with ``write``)."""

    def __init__(self, app, stream):
        self.app = app
        self.stream = stream

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        start, wall = time.perf_counter(), time.time()
        got = {"status": 499, "bytes": 0}

        async def counted(message):
            if message["type"] == "http.response.start":
                got["status"] = message["status"]
            elif message["type"] == "http.response.body" and scope["method"] != "HEAD":
                # the server sends no body in answer to HEAD, whatever the app gives it
                got["bytes"] += len(message.get("body", b""))
            await send(message)

        try:
            await self.app(scope, receive, counted)
        except Exception:
            if got["status"] == 499:  # the server's error page answers it
                got["status"] = 500
            raise
        finally:
            self._write(scope, wall, got, (time.perf_counter() - start) * 1e3)

    def _write(self, scope, wall: float, got: dict, ms: float) -> None:
        when = datetime.fromtimestamp(wall, timezone.utc).isoformat(timespec="milliseconds")
        path = scope.get("root_path", "") + scope["path"]
        if scope.get("query_string"):
            path += "?" + scope["query_string"].decode("latin-1")
        line = f"{when.replace('+00:00', 'Z')} {scope['method']} {path} "
        line += f"{got['status']} {got['bytes']} {ms:.1f}\n"
        try:
            self.stream.write(line)
            self.stream.flush()
        except (OSError, ValueError):  # a closed or full log must not fail the request
            pass
