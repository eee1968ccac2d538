"""Files a user hands over are bounded before they are read. JSON (an image, a macro memory
file, the flash record): a FIFO or a device is never opened (it would block or never end), and
a file larger than `MAX_JSON_BYTES` is refused with its size, each by the message and exit
of the file's own reader. And no command opens a FIFO it is given in place of a file."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang.cli import main
from mplang.lang import limits
from mplang.m8194h.flash import ImageError, load_image
from mplang.m8194h.flash.record import FlashRecord
from mplang.m8194h.sim import service
from mplang.m8194h.sim.controller import VirtualController

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def fifo(tmp_path: Path) -> Path:
    path = tmp_path / "image.json"
    os.mkfifo(path)  # reading it would wait for a writer for ever
    return path


def test_an_image_that_is_a_fifo_is_refused_unread(fifo: Path) -> None:
    with pytest.raises(ImageError, match="not a regular file"):
        load_image(fifo)
    result = CliRunner().invoke(main, ["disasm", str(fifo)])
    assert result.exit_code not in (0, 70) and "Traceback" not in result.output


def test_a_memory_file_that_is_a_fifo_is_refused_unread(fifo: Path) -> None:
    with pytest.raises(service.ServiceError, match="not a regular file"):
        service.load_memory(VirtualController(), fifo)


def test_files_over_the_limit_are_refused_with_their_size(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    big = tmp_path / "big.json"
    big.write_text('{"format": "x", "pad": "' + "a" * 2000 + '"}')
    monkeypatch.setattr(limits, "MAX_JSON_BYTES", 1000)
    with pytest.raises(ImageError, match="more than the 1,000 mpc reads"):
        load_image(big)
    with pytest.raises(service.ServiceError, match="more than the 1,000 mpc reads"):
        service.load_memory(VirtualController(), big)
    monkeypatch.setattr("mplang.m8194h.flash.record.MAX_JSON_BYTES", 1000)
    record = FlashRecord(big)
    assert record.refused is not None and "more than the 1,000 mpc reads" in record.refused


@pytest.mark.parametrize("args", [
    ["build", "{fifo}.mp"], ["lint", "{fifo}.mp"], ["fmt", "--check", "{fifo}.mp"],
    ["run", "{fifo}.mp"], ["disasm", "{fifo}.json"], ["import", "{fifo}.c"],
    ["flash", "{fifo}.json", "--dry-run"], ["sim", "{fifo}.mp", "--duration", "0"],
    ["sim", "--memory", "{fifo}.json", "--duration", "0"],
    ["run", "--machine", "{fifo}.toml", str(ROOT / "samples" / "tour.mp")],
    ["lint", "--project", "{fifo}.toml", str(ROOT / "samples" / "tour.mp")],
], ids=lambda args: " ".join(a for a in args if not a.startswith("/")))
def test_every_command_refuses_a_fifo_without_opening_it(tmp_path: Path,
                                                          args: list[str]) -> None:
    """A FIFO in place of any file a command reads: a clear refusal with a non-zero exit
    at once, where reading it would wait for a writer for ever."""
    base = tmp_path / "pipe"
    for suffix in (".mp", ".json", ".c", ".toml"):
        os.mkfifo(f"{base}{suffix}")
    argv = [a.replace("{fifo}", str(base)) for a in args]
    result = subprocess.run([sys.executable, "-m", "mplang", *argv], capture_output=True,
                            text=True, timeout=60, cwd=tmp_path)
    assert result.returncode not in (0, 70), result.stderr
    assert "not a regular file" in result.stderr and "Traceback" not in result.stderr
