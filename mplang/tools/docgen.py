"""Generate docs/checks/*.md (one page per rule), docs/runtime/*.md (one page per run-time
finding) and docs/commands.md (the catalogue).

Run `python -m mplang.tools.docgen` after changing rules.py, runtime_rules.py or the catalogue;
a test fails while the committed docs differ from what this writes.
"""

from __future__ import annotations

import sys
from pathlib import Path

from mplang.csim import profile as csim_profile
from mplang.fatek import profile as fatek_profile
from mplang.ir import catalogue
from mplang.ir.catalogue import Command
from mplang.lang.rules import RULES, Rule
from mplang.lang.runtime_rules import RUNTIME_RULES

ROOT = Path(__file__).resolve().parents[2]


def rule_page(rule: Rule, example: str | None) -> str:
    lines = [f"# {rule.code} `{rule.name}` ({rule.severity.value})", "", rule.summary, "",
             "## Why", "", rule.why, ""]
    if rule.device:
        lines += ["## What the device would do", "",
                  f"Downloading such a program would fail on the controller: {rule.device}.", ""]
    lines += ["## How to fix it", "", rule.fix, ""]
    if example:
        lines += ["## Example", "", "```", example.rstrip(), "```", ""]
    return "\n".join(lines)


def checks_index() -> str:
    lines = ["# Check codes", "",
             "Every diagnostic of `mpc build` / `mpc lint` has a stable code. Errors (`E`) stop "
             "the build; warnings (`W`) do not, unless `--werror` is given.", "",
             "| code | name | severity | summary |", "|---|---|---|---|"]
    for rule in RULES.values():
        lines.append(f"| [{rule.code}]({rule.code}.md) | `{rule.name}` | "
                     f"{rule.severity.value} | {rule.summary} |")
    return "\n".join(lines) + "\n"


def runtime_page(rule: Rule) -> str:
    """One run-time finding: what it means, what the device shows, how to fix it."""
    lines = [f"# {rule.code} `{rule.name}` ({rule.severity.value})", "", rule.summary, "",
             "`mpc run` and `mpc plot` report it as `FILE:LINE:COL: "
             f"{rule.severity.value}[{rule.code}]: message` at the source line that raised it "
             "(also inside INCLUDEd and `std:` files), with one `note: called from ...` per "
             "calling program; `mpc run --json` gives it as the `\"error\"` object "
             "(docs/cli.md).", "", "## Why", "", rule.why, ""]
    if rule.device:
        lines += ["## What the device shows", "", f"On the controller: {rule.device}.", ""]
    lines += ["## How to fix it", "", rule.fix, ""]
    return "\n".join(lines)


def runtime_index() -> str:
    lines = ["# Run-time findings", "",
             "Every way a run on a virtual controller (`mpc run`, `mpc plot`) can fail, and "
             "what it could not simulate, has a stable code, as the check codes of `mpc build` "
             "have (docs/checks/). Errors end the run (exit code 5); warnings do not.", "",
             "| code | name | severity | summary |", "|---|---|---|---|"]
    for rule in RUNTIME_RULES.values():
        lines.append(f"| [{rule.code}]({rule.code}.md) | `{rule.name}` | "
                     f"{rule.severity.value} | {rule.summary} |")
    return "\n".join(lines) + "\n"


def _param_text(command: Command) -> str:
    parts = []
    for p in command.params:
        extra = []
        if p.min is not None or p.max is not None:
            low = "" if p.min is None else p.min
            high = "" if p.max is None else p.max
            extra.append(f"{low}..{high}")
        if p.values:
            extra.append("values " + ", ".join(str(v) for v in p.values))
        if p.symbols:
            extra.append(", ".join(f"{k}={v}" for k, v in p.symbols.items()))
        if p.var:
            extra.append("VARn allowed")
        detail = f" ({'; '.join(extra)})" if extra else ""
        parts.append(f"`{p.name}` {p.type} {p.kind}{detail}")
    return "<br>".join(parts) or "none"


def commands_page() -> str:
    cat = catalogue.load()
    lines = ["# Command reference", "",
             "Generated from `stdlib/m8194h/commands.toml`. In `.mp` source a macro command "
             "is written by its short name with arguments in the C API order after the handle "
             "and slave address (`FIXED_MOVE X, 1000`). Scope: where the device accepts the "
             "command (RTC = real time only, from the host). Lines: macro lines it occupies.",
             "", "| name | vendor | section | code | scope | lines | parameters |",
             "|---|---|---|---|---|---|---|"]
    for command in cat.commands:
        if not command.is_macro:
            continue
        scope = "/".join(s.upper() for s in sorted(command.scope))
        code = f"0x{command.code:04X}" if command.code is not None else "-"
        targets = "" if command.targets == {"rs", "et"} else " (RS only)"
        lines.append(f"| `{command.short_name}`{targets} | {command.name} | {command.section} | "
                     f"{code} | {scope} | {command.line_cost} | {_param_text(command)} |")
    lines += ["", "## Real-time commands (not allowed in programs)", "",
              ", ".join(f"`{c.name}`" for c in cat.commands if not c.is_macro), ""]
    return "\n".join(lines)


def choices_page() -> str:
    """Every place where the manuals contradict themselves, and what mplang does there."""
    cat = catalogue.load()
    lines = ["# Device choices", "",
             "The M8194H manuals contradict themselves in places. Each choice below is data "
             "(`stdlib/m8194h/device.toml` keys ending in `_choice`, and the `choice` field of "
             "catalogue rows); change the data, not the code, if a device proves otherwise. "
             "Line numbers: RS = the RS-M8194H manual, ET = the ET-M8194H manual.", "",
             "## Device profile", ""]

    def walk(table: dict[str, object], prefix: str) -> None:
        for key, value in table.items():
            if isinstance(value, dict):
                walk(value, f"{prefix}{key}.")
            elif key.endswith("_choice"):
                setting = key.removesuffix("_choice")
                current = table.get(setting, "(see text)")
                lines.append(f"- **{prefix}{setting}** = `{current}`: {value}")

    walk(cat.profile.raw, "")
    lines += ["", "## Command catalogue", ""]
    for command in cat.commands:
        if command.choice:
            lines.append(f"- **{command.name}** ({command.section}): {command.choice}")
    lines += ["", "## CSIM RS232 command set", "",
              "What the CSIM command list (CS = the CSIM RS232 ASCII command list, the "
              "vendor's document) leaves undefined or contradicts, and the reading mplang "
              "takes: `stdlib/csim/device.toml` "
              "(and `from_mp.toml` for `--target csim`). See docs/csim.md.", ""]
    walk(csim_profile.load().raw, "")
    lines += ["", "## FATEK FBs-PLC positioning programs", "",
              "What the FBs-PLC chapter (FB = chapter 11 of the FATEK FBs-PLC manual, the "
              "vendor's document) leaves undefined or contradicts, and the reading mplang "
              "takes: `stdlib/fatek/device.toml`. "
              "See docs/fatek.md.", ""]
    walk(fatek_profile.load().raw, "")
    return "\n".join(lines) + "\n"


def generated() -> dict[Path, str]:
    pages: dict[Path, str] = {ROOT / "docs" / "checks" / "README.md": checks_index(),
                              ROOT / "docs" / "commands.md": commands_page(),
                              ROOT / "docs" / "device-choices.md": choices_page()}
    pages[ROOT / "docs" / "runtime" / "README.md"] = runtime_index()
    for code, rule in RUNTIME_RULES.items():
        pages[ROOT / "docs" / "runtime" / f"{code}.md"] = runtime_page(rule)
    examples = ROOT / "tests" / "data" / "checks"
    for code, rule in RULES.items():
        sample = next((examples / f"{code}{suffix}" for suffix in (".mp", ".fbs", ".csim")
                       if (examples / f"{code}{suffix}").exists()), None)
        text = sample.read_text() if sample is not None else None
        pages[ROOT / "docs" / "checks" / f"{code}.md"] = rule_page(rule, text)
    return pages


def main() -> int:
    pages = generated()
    for path, text in pages.items():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    print(f"wrote {len(pages)} pages")
    return 0


if __name__ == "__main__":
    sys.exit(main())
