"""mplang: a compiled macro-program toolchain for ICP DAS M8194H motion controllers."""

__version__ = "0.1.0"

from mplang import _moved

_moved.install()
