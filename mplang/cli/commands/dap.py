"""`mpc dap`: the debug adapter for .mp programs on the virtual controller, over stdio."""

from __future__ import annotations

import logging
import sys

import click

from mplang.cli.common import EXIT_USAGE, guarded


@click.command("dap", short_help="Debug adapter (DAP) for .mp programs (editors).")
@click.option("-v", "--verbose", is_flag=True, help="Log what the adapter does to stderr.")
@guarded
def command(verbose: bool) -> None:
    """Debug .mp programs on the virtual controller: editors start `mpc dap` and speak the
    Debug Adapter Protocol over its standard input and output. The program, the MP to call,
    stopOnEntry and a machine file come with the launch request (docs/debug.md)."""
    from mplang.tools.dap import serve

    if sys.stdin is None or sys.stdin.isatty():
        click.echo("mpc dap: speaks the Debug Adapter Protocol on standard input/output; start "
                   "it from an editor (see docs/debug.md)", err=True)
        sys.exit(EXIT_USAGE)
    logging.basicConfig(stream=sys.stderr, level=logging.DEBUG if verbose else logging.WARNING,
                        format="mpc dap: %(levelname)s: %(message)s")
    serve(sys.stdin.buffer, sys.stdout.buffer)
