"""`mpc`: the command line, a thin shell over the library and the family registry
(`mplang.family.registry`).

Every command lives in its own module of `mplang.cli.commands` and defines `command`; the group
finds them there (module `import_` is command `import`), so adding a command touches no other
file, and a command's heavy imports (pymodbus, matplotlib, pygls) load only when it runs.

Exit codes (also in docs/cli.md):
  0 success            1 errors in the sources     2 bad command-line usage
  3 input files missing or unreadable               4 output cannot be written
  5 the program failed or did not finish on the virtual controller
  6 an endpoint cannot be opened (port in use, no such serial device): mpc sim, mpc lsp,
     and mpc flash to a CSIM (its serial port)
  7 mpc flash: the device cannot be reached (refused, no answer, no such serial port)
  8 mpc flash: the device refused a program, or cannot take the image (word order)
  9 mpc flash: the device did not confirm a download (download-status registers; a CSIM:
     its echo, replies or listing differ from what was sent)
  10 mpc flash: interrupted: the link failed beyond --retries, the device stayed busy, or
     Ctrl-C / SIGTERM; programs after the last verified one may be missing
  11 mpc flash --fleet: devices failed in different ways (the table says which and how)
  12 mpc fmt --check: some files are not formatted
  13 mpc import: converted with omissions (each named on standard error at its C line)
  14 mpc disasm: some frames could not be carried over exactly (named on standard error)
  15 an optional dependency is not installed (the plot, lsp, monitor extras)
  70 internal error (a bug in mpc: please report it with the input)
  141 standard output was closed early (`mpc ... | head`): mpc stops quietly

Errors of mpc itself read `mpc: error: MESSAGE`; usage errors are click's (`Usage: ...`,
`Error: ...`, exit 2); diagnostics of sources keep the gcc-style first line
`FILE:LINE:COL: error[CODE]: MESSAGE` (docs/cli.md, "Terminal output").
"""

from __future__ import annotations

import importlib
import os
import re
import sys
from functools import cache
from pathlib import Path
from typing import Any

import click

from mplang import __version__
from mplang.cli import commands
from mplang.cli.style import COLOR_CHOICES, error, quiet_option, set_color
from mplang.lang import heap

EXIT_BROKEN_PIPE = 141
"""128 + SIGPIPE: what a shell reports for a program that stopped because its reader left."""


def __getattr__(name: str) -> Any:
    """The exit codes of `mplang.cli.common`, imported when asked for: `mpc --version` and
    `mpc --help` do not load what the commands share (the compiler's options, the project
    file)."""
    if name.startswith("EXIT_"):
        from mplang.cli import common

        return getattr(common, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

__all__ = [
    "EXIT_BROKEN_PIPE",
    "EXIT_FLEET_MIXED",
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_LEASED",
    "EXIT_MISSING_EXTRA",
    "EXIT_NOT_EXACT",
    "EXIT_NO_DEVICE",
    "EXIT_NO_INPUT",
    "EXIT_OK",
    "EXIT_OMISSIONS",
    "EXIT_OUTPUT",
    "EXIT_OUT_OF_SYNC",
    "EXIT_REJECTED",
    "EXIT_RUN_FAILED",
    "EXIT_SOURCE_ERRORS",
    "EXIT_TRANSPORT",
    "EXIT_UNVERIFIED",
    "EXIT_USAGE",
    "EXIT_WOULD_REFORMAT",
    "main",
]


def _module_name(command_name: str) -> str:
    return f"{command_name}_" if command_name in ("import",) else command_name


def short_help_of(command_name: str) -> str | None:
    """The `short_help` a command's module declares in `@click.command("NAME",
    short_help="...")`, or None when it is written otherwise (then the command is imported)."""
    path = Path(commands.__path__[0]) / f"{_module_name(command_name)}.py"
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return None
    found = re.search(r'^@click\.command\("' + re.escape(command_name) +
                      r'", short_help="([^"\\]*)"\)$', text, re.MULTILINE)
    return found.group(1).strip() if found else None


def _tolerant_output() -> None:
    """Standard output and error that cannot encode every character (a pipe or console in
    Windows' cp1252) write what they cannot as escapes (`\\u2192`), never fail: a source
    line or a file name quoted back may hold any character. UTF-8 streams are left alone."""
    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)  # None: replaced (tests, pytest)
        encoding = getattr(stream, "encoding", None) or "utf-8"
        if reconfigure is not None and not encoding.lower().replace("-", "").startswith("utf"):
            reconfigure(errors="backslashreplace")


@cache
def _command_modules() -> list[str]:
    """The modules of `mplang.cli.commands`, read from its directory (pkgutil only for a
    package that is not one: a zip import), as pkgutil names them: a file of a module suffix,
    or a directory with an `__init__`. Read once a process: resolving a command asks twice."""
    from importlib.machinery import all_suffixes

    directory = commands.__path__[0]
    try:
        entries = list(os.scandir(directory))
    except OSError:
        import pkgutil

        return [info.name for info in pkgutil.iter_modules(commands.__path__)]
    suffixes = sorted(all_suffixes(), key=len, reverse=True)
    names = set()
    for entry in entries:
        if entry.is_dir():
            if "." not in entry.name and any(os.path.isfile(os.path.join(entry.path,
                                                                         "__init__" + suffix))
                                             for suffix in suffixes):
                names.add(entry.name)
            continue
        suffix = next((s for s in suffixes if entry.name.endswith(s)), None)
        if suffix is not None and "." not in entry.name[:-len(suffix)]:
            names.add(entry.name[:-len(suffix)])
    names.discard("__init__")
    return sorted(names)


class CommandPackage(click.Group):
    """A click group whose commands are the modules of `mplang.cli.commands`."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(name.rstrip("_") for name in _command_modules()
                      if not name.startswith("_"))

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in self.list_commands(ctx):
            return None
        module = importlib.import_module(f"{commands.__name__}.{_module_name(cmd_name)}")
        command: click.Command = module.command
        return command

    def resolve_command(self, ctx: click.Context, args: list[str]
                        ) -> tuple[str | None, click.Command | None, list[str]]:
        """click's, with a did-you-mean for a mistyped command (`mpc biuld`: "did you mean
        'build'?"), as git and cargo answer."""
        name = args[0] if args else ""
        if args and not name.startswith("-") and self.get_command(ctx, name) is None:
            import difflib

            close = difflib.get_close_matches(name, self.list_commands(ctx), n=3, cutoff=0.6)
            if close:
                meant = " or ".join(f"'{c}'" for c in close)
                ctx.fail(f"No such command '{name}'; did you mean {meant}?")
        resolved = super().resolve_command(ctx, args)
        heap.started()  # its modules are imported: mplang.lang.heap
        return resolved

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """`mpc --help`'s list of commands, as click writes it, with each command's
        `short_help` read from its module's text instead of importing every command (and
        with it the compiler, pymodbus, pygls) to print one line each."""
        names = self.list_commands(ctx)
        if not names:
            return
        limit = formatter.width - 6 - max(len(name) for name in names)
        rows = []
        for name in names:
            short = short_help_of(name)
            if short is None:
                command = self.get_command(ctx, name)
                if command is None or command.hidden:
                    continue
                short = command.get_short_help_str(limit)
            rows.append((name, short))
        with formatter.section("Commands"):
            formatter.write_dl(rows)

    def main(self, *args: Any, **kwargs: Any) -> Any:
        """The last flush of standard output can meet a closed pipe too: quietly, as well."""
        _tolerant_output()
        collector_was_on = heap.starting()  # off while the command's modules are imported
        try:
            return super().main(*args, **kwargs)
        finally:
            heap.finished(collector_was_on)
            try:
                if not sys.stdout.closed:  # `mpc lsp` closes it when the client leaves
                    sys.stdout.flush()
            except BrokenPipeError:
                _quiet_broken_pipe()
                sys.exit(EXIT_BROKEN_PIPE)

    def invoke(self, ctx: click.Context) -> Any:
        """Every command's errors in one style, and a closed pipe ends quietly, once for the
        whole CLI."""
        try:
            return super().invoke(ctx)
        except click.UsageError:
            raise  # click's own form: the usage line, then the message
        except click.ClickException as exc:
            error(exc.format_message())
            ctx.exit(exc.exit_code)
        except BrokenPipeError:
            _quiet_broken_pipe()
            ctx.exit(EXIT_BROKEN_PIPE)


def _quiet_broken_pipe() -> None:
    """The reader of standard output left (`mpc fmt --diff | head -1`): point standard output
    at /dev/null so the interpreter's last flush cannot fail again (Python's documented recipe,
    library/signal.html, "Note on SIGPIPE")."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # no real file descriptor (a test runner)
        pass


@click.group(cls=CommandPackage, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="mpc")
@click.option("--color", type=click.Choice(COLOR_CHOICES), default="auto", show_default=True,
              help="Colour: on a terminal (auto, and never with NO_COLOR set), always, never.")
@quiet_option
@click.pass_context
def main(ctx: click.Context, color: str) -> None:
    """mpc: compile, check, run and download M8194H macro programs (.mp), and FATEK
    FBs-PLC positioning tables and CSIM programs (--target, .fbs, .csim)."""
    set_color(ctx, color)
