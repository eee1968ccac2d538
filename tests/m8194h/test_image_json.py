"""The image JSON written through json's C encoder is, byte for byte, the indented form
(json.dumps(..., indent=2)) with each frame and the frame_lines list on one line."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest

from mplang.lang.digest import sha256
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


def _defined_id(result: BuildResult) -> str:
    """The build id as defined: the hash of the JSON of what would be downloaded, the
    content encoded whole (`build_id` and `render_json` put that text together from each
    program's frames encoded once)."""
    content: list[object] = [result.word_order, [p.frames for p in result.programs]]
    if result.init is not None:
        content.append({"init": result.init.frames})
    if result.triggers is not None:
        content.append({"triggers": result.triggers.to_json()["entries"]})
    return sha256(json.dumps(content).encode()).hexdigest()[:16]


@pytest.mark.parametrize("path", SAMPLES, ids=lambda p: p.name)
def test_the_build_id_is_the_hash_of_the_content_encoded_whole(path: Path) -> None:
    result = compile_paths([path])
    assert result.build_id() == _defined_id(result)
    assert json.loads(render_json(result))["build_id"] == _defined_id(result)


def test_an_image_with_init_triggers_and_a_quoted_source_name(tmp_path: Path) -> None:
    """Members written without json.dumps (the source's name, with a quote, a backslash
    and a letter beyond ASCII) are escaped as it escapes them; the INIT and TRIGGERS
    tables count in the id."""
    source = tmp_path / 'na\u00efve "q" \\.mp'
    shutil.copy(ROOT / "samples" / "controller" / "controller.mp", source)
    result = compile_paths([source])
    assert result.ok and result.init is not None and result.triggers is not None
    assert render_json(result) == _indented(result)
    assert result.build_id() == _defined_id(result)
    empty = BuildResult([], word_order=1)
    assert render_json(empty) == _indented(empty)
    assert empty.build_id() == _defined_id(empty)
