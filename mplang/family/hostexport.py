"""`mpc export`: the host's view of a build (`HostView`) written for a host program, an HMI
or a SCADA: JSON (the view itself), CSV tag lists, a C header, a Python module and a C#
class. Every one carries the build id, so a host can compare it with the device's at start.
"""

from __future__ import annotations

import csv
import io
import json
import re
from collections.abc import Callable

from mplang.family.hostview import HostView

EXPORT_FORMATS = ("json", "csv", "c", "python", "csharp")
CSV_HEADER = ("name", "kind", "device_name", "register", "function", "words", "type",
              "word_order", "access", "source")
_NOT_IDENT = re.compile(r"[^A-Za-z0-9_]")


def render(view: HostView, fmt: str) -> str:
    """The view in one of `EXPORT_FORMATS`."""
    renderers: dict[str, Callable[[HostView], str]] = {
        "json": lambda v: json.dumps(v.to_json(), indent=2) + "\n",
        "csv": render_csv, "c": render_c, "python": render_python, "csharp": render_csharp}
    return renderers[fmt](view)


def _ident(name: str) -> str:
    """A name as an upper-case identifier of C, Python and C# (other characters become _)."""
    return _NOT_IDENT.sub("_", name).upper()


def _commands(view: HostView) -> bool:
    """Whether the device is spoken to in commands (a CSIM: `G $LABEL`, `?Rk`, `Rk=v`)
    rather than in Modbus registers."""
    return view.protocol != "modbus"


def render_csv(view: HostView) -> str:
    """One row per tag, for HMI and SCADA tag import: the build id first (kind `build`, the
    id in `device_name`), then each program the host can call (write `device_name`'s number
    to `register`; a CSIM: send the command in `function`) and each declared variable (a
    CSIM: `register` is k of Rk, `function` the commands that read and write it). CONSTs
    are no device tags: they are in the other formats."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(CSV_HEADER)
    writer.writerow(["build_id", "build", view.build_id, "", "", "", "", "", "", ""])
    for p in view.programs:
        if _commands(view):
            writer.writerow([p.name or p.device_name, p.kind, p.device_name, "", p.function,
                             "", "", "", "send", p.source])
            continue
        if p.register is None:
            continue
        writer.writerow([p.name or p.device_name, p.kind, p.device_name, p.register,
                         p.function, 1, "uint16", "", "write", p.source])
    for v in view.variables:
        writer.writerow([v.name, v.kind, v.device_name, v.register, v.function, v.words,
                         v.type, v.word_order, v.access, v.source])
    return out.getvalue()


def _comment(text: str) -> str:
    """Text safe inside a C or C# block comment."""
    return text.replace("*/", "* /")


def render_c(view: HostView) -> str:
    """A header of #defines (warning-free under -Wall -Werror): build id, word order, the
    register a program number is written to, each program's number, each variable's
    first holding register and word count, each CONST; for a device spoken to in commands
    (a CSIM), each program's call (`G $LABEL`) and each variable's device name instead."""
    out = [f"/* The host's view of mplang build {view.build_id}: written by mpc export "
           "--format c. Do not edit. */",
           "#ifndef MPC_HOST_H", "#define MPC_HOST_H", "",
           f"#define MPC_BUILD_ID \"{view.build_id}\""]
    if _commands(view):
        out += ["/* send MPC_CALL_x (then CR) to start a program; read a variable with ?name, "
                "write it with name=value */", ""]
        out += [f"#define MPC_CALL_{_ident(p.name)} \"{p.function}\"  "
                f"/* {_comment(p.source)} */" for p in view.programs if p.name]
        out += [f"#define MPC_VAR_{_ident(v.name)} \"{v.device_name}\"  /* {v.type}, "
                f"{_comment(v.source)} */" for v in view.variables]
    else:
        out += _c_registers(view)
    for c in view.consts:
        out.append(f"#define MPC_CONST_{_ident(c.name)} ({c.value}L)  "
                   f"/* {_comment(c.source)} */")
    out += ["", "#endif /* MPC_HOST_H */"]
    return "\n".join(out) + "\n"


def _c_registers(view: HostView) -> list[str]:
    """The #defines of a Modbus device: word order, call register, numbers, registers."""
    out = ["/* 32-bit values: MPC_WORD_ORDER 0 puts the high word in the first register, 1 the "
           "low word */",
           f"#define MPC_WORD_ORDER {view.word_order}"]
    call = next((p.register for p in view.programs if p.register is not None), None)
    if call is not None:
        out += ["/* a program starts when its number is written to this holding register */",
                f"#define MPC_CALL_REGISTER {call}"]
    out.append("")
    for p in view.programs:
        if p.name:
            out.append(f"#define MPC_{p.kind.upper()}_{_ident(p.name)} {p.slot}  "
                       f"/* {_comment(p.source)} */")
    for v in view.variables:
        name = _ident(v.name)
        out.append(f"#define MPC_REG_{name} {v.register}  /* {v.device_name}, {v.type}, "
                   f"{_comment(v.source)} */")
        out.append(f"#define MPC_WORDS_{name} {v.words}")
    return out


def render_python(view: HostView) -> str:
    """A module of constants, and the tables by name."""
    if _commands(view):
        return _render_python_commands(view)
    programs = {p.name: p.slot for p in view.programs if p.name and p.kind == "mp"}
    variables = {v.name: {"register": v.register, "words": v.words, "type": v.type,
                          "device_name": v.device_name} for v in view.variables}
    consts = {c.name: c.value for c in view.consts}
    call = next((p.register for p in view.programs if p.register is not None), None)
    out = [f'"""The host\'s view of mplang build {view.build_id}: written by `mpc export '
           '--format python`. Do not edit."""', "",
           f"BUILD_ID = {view.build_id!r}",
           f"WORD_ORDER = {view.word_order}  # 0: the high word of a 32-bit value first",
           f"CALL_REGISTER = {call!r}  # write a program's number here to start it", ""]
    out += [f"MP_{_ident(name)} = {slot}" for name, slot in programs.items()]
    out += [f"REG_{_ident(v.name)} = {v.register}  # {v.device_name}, {v.type}"
            for v in view.variables]
    out += [f"CONST_{_ident(c.name)} = {c.value}" for c in view.consts]
    out += ["", f"PROGRAMS = {programs!r}", f"VARIABLES = {variables!r}",
            f"CONSTS = {consts!r}"]
    return "\n".join(out) + "\n"


def _render_python_commands(view: HostView) -> str:
    """The Python module of a device spoken to in commands."""
    calls = {p.name: p.function for p in view.programs if p.name}
    variables = {v.name: {"device_name": v.device_name, "type": v.type}
                 for v in view.variables}
    consts = {c.name: c.value for c in view.consts}
    out = [f'"""The host\'s view of mplang build {view.build_id} for a {view.family}: written '
           'by `mpc export --format python`. Do not edit."""', "",
           f"BUILD_ID = {view.build_id!r}",
           "# send a CALL_ line (then CR) to start a program; read a variable with '?' + its "
           "name, write it with name=value", ""]
    out += [f"CALL_{_ident(name)} = {command!r}" for name, command in calls.items()]
    out += [f"VAR_{_ident(v.name)} = {v.device_name!r}  # {v.type}" for v in view.variables]
    out += [f"CONST_{_ident(c.name)} = {c.value}" for c in view.consts]
    out += ["", f"CALLS = {calls!r}", f"VARIABLES = {variables!r}", f"CONSTS = {consts!r}"]
    return "\n".join(out) + "\n"


def render_csharp(view: HostView) -> str:
    """A static class of constants (namespace Mplang, class Build); for a device spoken to
    in commands (a CSIM), each program's call and each variable's device name as strings."""
    out = [f"// The host's view of mplang build {view.build_id}: written by mpc export "
           "--format csharp. Do not edit.",
           "namespace Mplang", "{", "    public static class Build", "    {",
           f"        public const string Id = \"{view.build_id}\";"]
    if _commands(view):
        out += [f"        public const string CALL_{_ident(p.name)} = \"{p.function}\";  "
                f"// {p.source}" for p in view.programs if p.name]
        out += [f"        public const string VAR_{_ident(v.name)} = \"{v.device_name}\";  "
                f"// {v.type}" for v in view.variables]
    else:
        out += _csharp_registers(view)
    for c in view.consts:
        out.append(f"        public const int CONST_{_ident(c.name)} = {c.value};")
    out += ["    }", "}"]
    return "\n".join(out) + "\n"


def _csharp_registers(view: HostView) -> list[str]:
    """The C# constants of a Modbus device: word order, call register, numbers, registers."""
    out = [f"        public const int WordOrder = {view.word_order};"]
    call = next((p.register for p in view.programs if p.register is not None), None)
    if call is not None:
        out.append(f"        public const int CallRegister = {call};")
    for p in view.programs:
        if p.name:
            out.append(f"        public const int {p.kind.upper()}_{_ident(p.name)} = "
                       f"{p.slot};  // {p.source}")
    for v in view.variables:
        out.append(f"        public const int REG_{_ident(v.name)} = {v.register};  "
                   f"// {v.device_name}, {v.type}")
    return out
