"""The ``gloffset`` command line: a thin layer over the library, one module per subcommand.

Every error gloffset raises on bad input is printed as one line on stderr
(``gloffset: error: ...``) with exit status 2; no traceback.
"""

from __future__ import annotations

import sys

import click

from .. import __version__
from ..errors import GloffsetError


class _Group(click.Group):
    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except GloffsetError as exc:
            click.echo(f"gloffset: error: {exc}", err=True)
            ctx.exit(2)
        except BrokenPipeError:  # e.g. piped into head
            sys.stderr.close()
            ctx.exit(1)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "--version", prog_name="gloffset")
def main():
    """Regions within a distance of curves and polygons on the sphere."""


from . import contains as _contains  # noqa: E402,F401  (registers the subcommands)
from . import offset as _offset  # noqa: E402,F401
from . import render as _render  # noqa: E402,F401
from . import tiles as _tiles  # noqa: E402,F401
