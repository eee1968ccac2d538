"""Shell completion of file names, for the FILE arguments of every command."""

from __future__ import annotations

import click
from click.shell_completion import CompletionItem


def complete_paths(ctx: click.Context, param: click.Parameter,
                   incomplete: str) -> list[CompletionItem]:
    """Let the shell complete file and directory names. A shell_complete function rather
    than `type=click.Path()`, which would also stat every argument while parsing and so
    change what bad names report (and exit with)."""
    return [CompletionItem(incomplete, type="file")]
