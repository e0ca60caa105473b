"""``gloffset serve``: a tile server of the offset regions of the inputs, any distance."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from ..errors import InputFormatError, OptionError
from ..shape import read
from . import main
from .options import number_option

if TYPE_CHECKING:
    from starlette.applications import Starlette


@main.command("serve")
@click.argument("inputs", metavar="INPUT...", nargs=-1, required=True)
@click.option("--host", default="127.0.0.1", show_default=True, help="Address to listen on.")
@click.option("--port", type=click.IntRange(0, 65535), default=8080, show_default=True)
@number_option("--cache-mb", low=0, default=256.0, help="Rendered tiles kept in memory, MB.")
@click.option(
    "--field-mb",
    type=click.FloatRange(min=0),
    default=256.0,
    show_default=True,
    help="Distance fields of tiles kept in memory, MB (256 KiB a tile): a tile whose field "
    "is kept is answered at any distance by a threshold.",
)
@click.option(
    "--cache-control",
    default="public, max-age=3600",
    show_default=True,
    help="The Cache-Control header of tiles.",
)
@number_option(
    "--queue",
    "queue_size",
    low=1,
    default=256,
    help="Tiles waiting to render at most; more are answered 503 with Retry-After.",
)
@number_option(
    "--render-timeout",
    low=0.1,
    default=60.0,
    help="Seconds a request waits for its tile; then 503 with Retry-After.",
)
@number_option(
    "--workers",
    low=1,
    default=1,
    help="Server processes sharing the port, each with its own GL context and caches.",
)
@click.option(
    "--access-log",
    metavar="FILE|-",
    is_flag=False,
    flag_value="-",
    default=None,
    help="Log a line per request (time, method, path, status, bytes, ms) to FILE, "
    "appended, or to standard output ('-', or the option alone). Default: no log.",
)
@click.option(
    "--cors",
    metavar="ORIGINS",
    default="*",
    show_default=True,
    help="The origins whose pages may use the tiles and answers (CORS headers): '*' any, "
    "a comma-separated list such as https://example.com,http://localhost:3000, or 'none'.",
)
def serve_cmd(
    inputs,
    host,
    port,
    cache_mb,
    field_mb,
    cache_control,
    queue_size,
    render_timeout,
    workers,
    access_log,
    cors,
):
    """Serve the offset regions of INPUT... as map tiles for any distance:
    /tiles/LAYER/127km/z/x/y.png, /tilejson/LAYER.json?distance=127km, distance-field
    tiles /field/LAYER/z/x/y.png (/field/LAYER.json), /offset/LAYER.geojson?distance=127km,
    /shape/LAYER.geojson, /distance/LAYER?lon=-100&lat=20 (metres), /layers, and at / a
    map and globe page with a distance slider, drawn in the browser from the field tiles
    (each INPUT is a layer named after its file stem). Pages of any origin may use them
    (--cors).

    One process renders on one GL thread, batching the tiles asked for together; for
    more throughput, --workers N runs N processes on the port (each with its own GL
    context, render thread and caches), or run several behind a load balancer. Stop
    with Ctrl-C. Needs pip install 'gloffset[serve]'.
    """
    try:
        import uvicorn

        from ..serve.app import ENVIRONMENT, cors_origins, create_app
    except ImportError:
        raise OptionError("gloffset serve needs: pip install 'gloffset[serve]'") from None
    origins = cors_origins(cors)  # before the inputs are read
    layers = {}
    for path in inputs:
        name = Path(path).stem
        if name in layers:
            raise InputFormatError(f"two inputs are named {name!r}: layers are named by file stem")
        layers[name] = read(path)
    opts = dict(
        cache_control=cache_control,
        queue_size=queue_size,
        cache_mb=cache_mb,
        field_mb=field_mb,
        render_timeout=render_timeout,
        access_log=access_log,
        cors=origins,
    )
    click.echo(
        f"gloffset serve: http://{host}:{port}/ ({', '.join(layers)}"
        + (f"; {workers} processes" if workers > 1 else "")
        + "); Ctrl-C stops",
        err=True,
    )
    target: str | Starlette  # the app, or its factory's import path
    kw: dict[str, Any]
    if workers > 1:  # each worker (spawned) reads the inputs and makes its own context
        paths = [str(Path(p).resolve()) for p in inputs]
        if access_log not in (None, "-"):  # each worker appends its lines to the file
            opts["access_log"] = str(Path(access_log).resolve())
        os.environ[ENVIRONMENT] = json.dumps({"inputs": paths, **opts})
        target, kw = "gloffset.serve.app:app_from_environment", {"factory": True}
        kw["workers"] = workers
    else:
        target, kw = create_app(layers, **opts), {}
    uvicorn.run(target, host=host, port=port, log_level="warning", **kw)
