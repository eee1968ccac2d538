"""`mpc lsp`: the language server for .mp files, over stdio (or TCP for debugging)."""

from __future__ import annotations

import logging
import sys

import click

from mplang.cli import style
from mplang.cli.common import (
    EXIT_TRANSPORT,
    EXIT_USAGE,
    guarded,
    parse_listen_port,
    parse_temps,
    require_extra,
)

LOG_FORMAT = "mpc lsp: %(levelname)s: %(message)s"


class _OneLineFormatter(logging.Formatter):
    """Errors as one line (exception type and message); --verbose keeps the tracebacks."""

    def format(self, record: logging.LogRecord) -> str:
        text = super().format(logging.makeLogRecord({**record.__dict__, "exc_info": None,
                                                     "exc_text": None}))
        if record.exc_info and record.exc_info[1] is not None:
            error = record.exc_info[1]
            text += f": {type(error).__name__}: {error}"
        return text


def require_pygls() -> None:
    """pygls is the optional `lsp` extra: say how to get it, instead of an import error."""
    require_extra("mpc lsp", "lsp", "pygls", "lsprotocol")


def _parse_pool(ctx: click.Context, param: click.Parameter, value: str | None
                ) -> range | None:
    """None when not given: the project file (or the default) decides."""
    return None if value is None else parse_temps(ctx, param, value)


@click.command("lsp", short_help="Language server for .mp files (editors).")
@click.option("--tcp", "listen", callback=parse_listen_port, default=None,
              metavar="[HOST:]PORT", help="Serve one client over TCP instead of stdio: PORT "
              "(a bare number is a port, on 127.0.0.1) or HOST:PORT.")
@click.option("--stdio", is_flag=True, help="Serve over standard input/output (the default; "
              "accepted because most editors pass it).")
@click.option("--target", type=click.Choice(["et", "rs"]), default=None,
              help="Controller the checks are for: ET-M8194H or RS-M8194H [default: the "
              "project file's, else et].")
@click.option("--temp-vars", callback=_parse_pool, default=None, metavar="FIRST-LAST",
              help="VAR pool for expression temporaries [default: the project file's, else "
              "500-511].")
@click.option("--allow-outside-includes", is_flag=True, default=None,
              help="Let INCLUDE reach files outside the project directory.")
@click.option("-v", "--verbose", is_flag=True, help="Log what the server does to stderr.")
@guarded
def command(listen: tuple[str, int] | None, stdio: bool, target: str | None,
            temp_vars: range | None, allow_outside_includes: bool | None,
            verbose: bool) -> None:
    """Run the language server for .mp files: diagnostics, hover, completion, navigation,
    formatting, symbols and slot budgets. Editors start it and speak LSP over its standard
    input/output (`--stdio`, the default)."""
    if stdio and listen is not None:
        raise click.UsageError("--stdio and --tcp exclude each other: choose one transport")
    require_pygls()
    from mplang.tools.lsp.server import create_server
    from mplang.tools.lsp.workspace import Overrides

    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter(LOG_FORMAT) if verbose
                         else _OneLineFormatter(LOG_FORMAT))
    logging.basicConfig(level=logging.INFO if verbose else logging.WARNING, handlers=[handler])
    server = create_server(Overrides(target, temp_vars, allow_outside_includes or None))
    if listen is None:
        if sys.stdin is None or sys.stdin.isatty():
            click.echo("mpc lsp: speaks LSP on standard input/output; start it from an "
                       "editor (see docs/lsp.md)", err=True)
            sys.exit(EXIT_USAGE)
        server.start_io()
        return
    host, port = listen
    click.echo(f"mpc lsp: listening on {host}:{port}", err=True)
    try:
        server.start_tcp(host, port)
    except OSError as exc:
        style.error(f"cannot listen on {host}:{port}: {exc.strerror or exc}")
        sys.exit(EXIT_TRANSPORT)
