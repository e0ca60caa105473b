"""``gloffset serve``: offsets rendered on demand as map tiles, for any distance.

:mod:`.service` renders tiles on one GL thread in batches and caches them; :mod:`.app`
is the HTTP side (Starlette). Needs the ``serve`` extra (starlette, uvicorn).
"""
