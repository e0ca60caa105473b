"""The ``gloffset`` command line: a thin layer over the library, one module per subcommand.

Every error gloffset raises on bad input, and every usage error (a missing or bad option), is
printed as one line on stderr (``gloffset: error: ...``) with exit status 2; no traceback.
Outputs are written with :mod:`gloffset.io.output`.
"""

from __future__ import annotations

import sys

import click

from .._version import __version__
from ..errors import GloffsetError

#: Raised by click for a bare ``gloffset`` (click >= 8.2): the help is shown, not an error line.
_HELP = getattr(click.exceptions, "NoArgsIsHelpError", ())


def _usage_error(exc: click.ClickException) -> None:
    """Print a click error (a missing option, a bad value) as one line."""
    if isinstance(exc, _HELP):
        raise exc
    hint = ""
    ctx = getattr(exc, "ctx", None)
    if ctx is not None:
        hint = f" (see '{ctx.command_path} --help')"
    click.echo(f"gloffset: error: {exc.format_message()}{hint}", err=True)


class _Group(click.Group):
    def make_context(self, info_name, args, parent=None, **extra):
        try:  # the group's own options
            return super().make_context(info_name, args, parent=parent, **extra)
        except click.ClickException as exc:
            _usage_error(exc)
            raise click.exceptions.Exit(2) from None

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except GloffsetError as exc:
            click.echo(f"gloffset: error: {exc}", err=True)
            ctx.exit(2)
        except click.ClickException as exc:  # a subcommand's options
            _usage_error(exc)
            ctx.exit(2)
        except BrokenPipeError:  # e.g. piped into head
            sys.stderr.close()
            ctx.exit(1)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "--version", prog_name="gloffset")
def main():
    """Regions within a distance of curves and polygons on the sphere."""


from . import contains as _contains  # noqa: E402,F401  (registers the subcommands)
from . import field as _field  # noqa: E402,F401
from . import offset as _offset  # noqa: E402,F401
from . import preview as _preview  # noqa: E402,F401
from . import render as _render  # noqa: E402,F401
from . import serve as _serve  # noqa: E402,F401
from . import tiles as _tiles  # noqa: E402,F401
