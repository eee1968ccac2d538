"""Package data read without importlib.resources (mplang.lang.packagedata): the same text as
importlib.resources gives, from a package directory and from a package imported out of a
zip archive (a wheel on sys.path), line ends read as text reads them."""

from __future__ import annotations

import sys
import zipfile
from collections.abc import Iterator
from importlib import resources
from pathlib import Path

import pytest

from mplang.lang import packagedata

DATA = b"first\r\nsecond\rthird\n\xc2\xb5\n"


@pytest.fixture
def packages(tmp_path: Path) -> Iterator[tuple[str, str]]:
    """Two packages holding `sub/data.txt`: one a directory, one inside a zip archive."""
    on_disk = tmp_path / "disk" / "pd_disk"
    (on_disk / "sub").mkdir(parents=True)
    (on_disk / "__init__.py").write_text("")
    (on_disk / "sub" / "data.txt").write_bytes(DATA)
    archive = tmp_path / "zipped.whl"
    with zipfile.ZipFile(archive, "w") as out:
        out.writestr("pd_zip/__init__.py", "")
        out.writestr("pd_zip/sub/data.txt", DATA)
    sys.path[:0] = [str(tmp_path / "disk"), str(archive)]
    try:
        yield "pd_disk", "pd_zip"
    finally:
        sys.path.remove(str(tmp_path / "disk"))
        sys.path.remove(str(archive))
        for name in ("pd_disk", "pd_zip"):
            sys.modules.pop(name, None)


def test_a_directory_and_a_zip_package_read_as_importlib_resources_reads_them(
        packages: tuple[str, str]) -> None:
    on_disk, zipped = packages
    assert packagedata.package_directory(on_disk) is not None
    assert packagedata.package_directory(zipped) is None
    for package in packages:
        expected = resources.files(package).joinpath("sub", "data.txt")
        assert packagedata.read_bytes(package, "sub", "data.txt") == DATA == \
            expected.read_bytes()
        assert packagedata.read_text(package, "sub", "data.txt") == \
            expected.read_text("utf-8") == "first\nsecond\nthird\n\u00b5\n"


def test_a_missing_file_is_an_oserror(packages: tuple[str, str]) -> None:
    for package in packages:
        with pytest.raises(OSError):
            packagedata.read_bytes(package, "sub", "absent.txt")


def test_the_catalogue_files_read_as_before() -> None:
    for family, name in (("m8194h", "commands.toml"), ("m8194h", "device.toml")):
        assert packagedata.read_text("mplang.stdlib", family, name) == resources.files(
            "mplang.stdlib").joinpath(family, name).read_text("utf-8")
