"""The data files shipped inside mpc's packages (the catalogue, device profiles, the grammar),
read without `importlib.resources` where the package is a directory on disk.

`importlib.resources` brings `tempfile`, and with it `shutil`, `bz2`, `lzma` and `random`,
and each `files()` call loads `importlib.readers` and `zipfile`: several milliseconds of
every short `mpc` run, for what is an `open()` of a file beside the package's `__init__.py`
in every ordinary install (a wheel installed by pip, an editable install, a checkout). A
package imported from a zip archive (a `.whl` on `sys.path`) has no such directory, and is
read through `importlib.resources` as before.
"""

from __future__ import annotations

import importlib
import os


def package_directory(package: str) -> str | None:
    """The directory of `package` (imported, as `importlib.resources` imports it), or None
    when it is not a directory on disk (a zip import)."""
    locations = getattr(importlib.import_module(package), "__path__", None) or ()
    for location in locations:
        if os.path.isdir(location):
            return str(location)
    return None


def read_bytes(package: str, *parts: str) -> bytes:
    """The bytes of the file `parts` (a path inside `package`, one name a part); OSError as
    `open` raises it when there is no such file."""
    directory = package_directory(package)
    if directory is None:
        from importlib import resources

        return resources.files(package).joinpath(*parts).read_bytes()
    with open(os.path.join(directory, *parts), "rb") as stream:
        return stream.read()


def read_text(package: str, *parts: str) -> str:
    """`read_bytes`, decoded as UTF-8 (every data file mpc ships is), each CR LF or lone CR
    read as LF, as a file opened as text (`Traversable.read_text`) reads them."""
    text = read_bytes(package, *parts).decode("utf-8")
    return text.replace("\r\n", "\n").replace("\r", "\n") if "\r" in text else text
