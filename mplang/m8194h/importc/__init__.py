"""`mpc import`: C programs written against the vendor API turned into `.mp` source.

`convert(text)` turns the text of a C file into a `Conversion` (the `.mp` text, what could not
be converted, and a line map); `read_c_file` decodes the file first. The package is split along
the steps:

- `reader`: the C tokenizer and the grouping of tokens into statements, blocks and comments;
- `expressions`: constant C expressions, parsed and evaluated (`Unconvertible` when they cannot);
- `values`: the file's constants and what an argument means as a macro operand;
- `importer`: the conversion of one file into macro lines through `mplang.ir.mpwriter`.

Every name callers use is re-exported here, so they import from `mplang.m8194h.importc`.
"""

from __future__ import annotations

from mplang.m8194h.importc.expressions import (
    CBin,
    CCall,
    CExpr,
    CName,
    CNum,
    CStr,
    CUnary,
    Unconvertible,
    parse_expression,
)
from mplang.m8194h.importc.expressions import _number as _number  # read directly by the tests
from mplang.m8194h.importc.importer import (
    Conversion,
    Importer,
    ImportWarning,
    convert,
    read_c_file,
)
from mplang.m8194h.importc.reader import Event, Token, events, tokenize

__all__ = [
    "CBin",
    "CCall",
    "CExpr",
    "CName",
    "CNum",
    "CStr",
    "CUnary",
    "Conversion",
    "Event",
    "ImportWarning",
    "Importer",
    "Token",
    "Unconvertible",
    "convert",
    "events",
    "parse_expression",
    "read_c_file",
    "tokenize",
]
