"""The image JSON written through json's C encoder is, byte for byte, the indented form
(json.dumps(..., indent=2)) with each frame and the frame_lines list on one line."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from mplang.m8194h.compiler import compile_paths
from mplang.m8194h.image import BuildResult, render_json

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = sorted(p for p in (ROOT / "samples").rglob("*.mp")
                 if compile_paths([p]).ok)


def _indented(result: BuildResult) -> str:
    """The pure-Python encoder's indented image, then every list of numbers (a frame, the
    frame_lines) folded onto one line; an image without programs keeps their list open on
    two lines, as images always have."""
    text = json.dumps(result.image(), indent=2)
    text = re.sub(r"\[\n\s*(-?\d+(?:,\n\s*-?\d+)*)\n\s*\]",
                  lambda m: "[" + re.sub(r",\n\s*", ", ", m.group(1)) + "]", text) + "\n"
    return text.replace('"programs": []', '"programs": [\n\n  ]')


@pytest.mark.parametrize("path", SAMPLES, ids=lambda p: p.name)
def test_the_image_is_the_indented_form(path: Path) -> None:
    result = compile_paths([path])
    assert render_json(result) == _indented(result)
