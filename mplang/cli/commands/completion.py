"""`mpc completion bash|zsh|fish`: print the shell completion script, click's own, so that
command names, options, choices and file names complete."""

from __future__ import annotations

import click
from click.shell_completion import get_completion_class

PROG_NAME = "mpc"
COMPLETE_VAR = "_MPC_COMPLETE"  # what `_MPC_COMPLETE=bash_source mpc` would read


@click.command("completion", short_help="Print the shell completion script (bash, zsh, fish).")
@click.argument("shell", type=click.Choice(["bash", "zsh", "fish"]))
@click.pass_context
def command(ctx: click.Context, shell: str) -> None:
    """Print the completion script for SHELL. Load it from the shell's start-up file:
    bash: eval "$(mpc completion bash)" in ~/.bashrc; zsh: eval "$(mpc completion zsh)" in
    ~/.zshrc; fish: mpc completion fish > ~/.config/fish/completions/mpc.fish"""
    completion_class = get_completion_class(shell)
    assert completion_class is not None  # the three choices are click's built-in shells
    script = completion_class(ctx.find_root().command, {}, PROG_NAME, COMPLETE_VAR).source()
    click.echo(script.rstrip("\n"))
