"""Every check the compiler makes, with its stable code.

Codes never change meaning once published; `docs/checks/<CODE>.md` is generated from this
table (`python -m mplang.tools.docgen`) and a test keeps the two in step. `device` names the
controller's own download error or illegal-function cause the rule prevents, if any.
"""

from __future__ import annotations

from mplang.lang.record import FrozenRecord
from mplang.lang.severity import Severity

E = Severity.ERROR
W = Severity.WARNING


class Rule(FrozenRecord):
    code: str
    name: str
    severity: Severity
    summary: str
    why: str
    fix: str
    device: str
    _fields = __match_args__ = ("code", "name", "severity", "summary", "why", "fix", "device")

    def __init__(self, code: str, name: str, severity: Severity, summary: str, why: str,
                 fix: str, device: str = "") -> None:
        self.__dict__.update(code=code, name=name, severity=severity, summary=summary, why=why,
                             fix=fix, device=device)


_RULES = [
    # ------------------------------------------------------------------ E1: reading sources
    Rule("E101", "syntax-error", E, "A line does not follow the statement syntax.",
         "Each line holds one statement: a declaration, a program header, a block keyword, an "
         "assignment or a command with comma-separated arguments.",
         "Compare the line with the statement forms in docs/language.md."),
    Rule("E102", "include-not-found", E, "An INCLUDE names a file that cannot be read.",
         "INCLUDE paths are resolved relative to the including file. Only a regular file is "
         "read: a FIFO, a device or a directory is named and never opened, so an INCLUDE "
         "cannot hang the build or read without end.",
         "Fix the path, or create the file."),
    Rule("E103", "include-cycle", E, "Files include each other in a cycle.",
         "Including a file that is already being included would repeat its programs forever.",
         "Remove one of the INCLUDE lines of the cycle."),
    Rule("E104", "include-outside-project", E,
         "An INCLUDE reaches outside the project directory.",
         "Builds must not depend on files outside the project unless asked to, so that a "
         "clone builds the same image everywhere.",
         "Move the file into the project, or pass --allow-outside-includes."),
    Rule("E105", "unreadable-source", E, "A source file cannot be read as UTF-8 text.",
         "The compiler reads .mp sources as UTF-8.", "Save the file as UTF-8 text."),
    Rule("E107", "expression-too-deep", E, "An expression too deeply nested to compile.",
         "The compiler follows expressions up to 100 levels deep (a 100-term sum; CONSTs "
         "defined through each other count too); deeper ones are generated text, never a "
         "program.", "Split it into several assignments or CONSTs."),
    Rule("E108", "number-too-long", E, "A number literal longer than any value it could be.",
         "Device values are 32-bit (at most 10 decimal digits); the compiler reads numbers of "
         "up to 20 significant digits, or 16 after 0x, so that constant arithmetic can "
         "still report a value out of range. Longer literals are refused where they stand.",
         "Write the value the device should hold."),
    Rule("E106", "include-inside-program", E, "INCLUDE inside an MP or ISR block.",
         "INCLUDE joins a whole file (its CONSTs, ALIASes and programs) to the build; it is "
         "not a macro that pastes lines into a program.",
         "Move the INCLUDE to the top level; use CALL to share code between programs."),
    # -------------------------------------------------------------- E2: names and constants
    Rule("E201", "unknown-command", E, "A command name is not in the M8194H catalogue.",
         "Commands are the manual's macro functions without their RSM_MACRO_/ETM_MACRO_ "
         "prefix (or the full vendor name).",
         "Use the suggested name, or look the command up in docs/commands.md."),
    Rule("E202", "unknown-name", E, "An operand names nothing known.",
         "Operands are numbers, CONSTs, ALIASes, VAR0..VAR511, axis names, program names "
         "(MPn/ISRn) or the symbolic constants of the command's parameter.",
         "Declare the name with CONST or ALIAS, or fix its spelling."),
    Rule("E203", "duplicate-definition", E, "A CONST or ALIAS name is defined twice.",
         "Names are global to a build; two definitions would make every use ambiguous.",
         "Rename or remove one definition."),
    Rule("E204", "variable-out-of-range", E, "A VARn index is beyond VAR511.",
         "The controller has 512 long variables, VAR0 to VAR511.", "Use VAR0..VAR511.",
         "parameter out of range (register 102 cause 0x02)"),
    Rule("E205", "reserved-name", E, "A CONST or ALIAS takes a reserved name.",
         "Keywords, command names, axis names and VARn/MPn/ISRn spellings are reserved.",
         "Choose another name."),
    Rule("E206", "constant-error", E, "A constant expression cannot be evaluated.",
         "CONST values and folded operands must be integers computable at compile time, "
         "without division by zero or circular definitions.",
         "Fix the expression."),
    Rule("E208", "var-pool-exhausted", E, "No free variable is left for a VAR declaration.",
         "Unpinned `VAR name` declarations take the lowest VARn of the pool (mpc.toml "
         "[project] var-pool, default VAR400..VAR499) that nothing in the build names.",
         "Widen the pool, or pin some variables with `VAR name @ VARn`."),
    Rule("E209", "variable-clash", E, "Two VAR declarations are pinned to the same VARn.",
         "A declared variable is storage of its own for the host to read and write; two "
         "names on one VARn would overwrite each other.",
         "Pin each to its own VARn; for a second name of one variable use ALIAS."),
    Rule("E207", "alias-target", E, "An ALIAS does not name a variable.",
         "ALIAS gives a name to a device variable VARn.", "Write ALIAS name = VARn."),
    # ---------------------------------------------------------------------- E3: structure
    Rule("E301", "statement-outside-program", E,
         "A statement stands outside any MP or ISR block.",
         "Only CONST, ALIAS and INCLUDE may appear at the top level.",
         "Move the statement into an MP ... END MP or ISR ... END ISR block."),
    Rule("E302", "program-not-closed", E, "An MP or ISR block has no END MP / END ISR.",
         "Every program must be closed; the close becomes its MP_CLOSE/MP_ISR_CLOSE line.",
         "Add END MP (or END ISR) after the program's last statement."),
    Rule("E303", "unmatched-end", E, "An END closes a block that is not open.",
         "END MP/END ISR/END IF/NEXT must match the innermost open block.",
         "Close the inner block first, or remove the stray END."),
    Rule("E304", "next-without-for", E, "NEXT without an open FOR.",
         "The device refuses a NEXT outside a loop.", "Remove the NEXT or add its FOR.",
         "download error 0x09"),
    Rule("E305", "for-not-closed", E, "FOR without NEXT.",
         "Every FOR must be closed by NEXT inside the same program.", "Add NEXT.",
         "download error 0x0A"),
    Rule("E306", "exit-for-outside-loop", E, "EXIT FOR outside a FOR loop.",
         "EXIT FOR leaves the innermost loop; outside a loop there is nothing to leave.",
         "Remove it, or use EXIT to leave the program.", "download error 0x08"),
    Rule("E307", "else-outside-if", E, "ELSE outside an IF block, or a second ELSE.",
         "An IF block takes at most one ELSE.", "Remove the extra ELSE.",
         "download error 0x03"),
    Rule("E308", "end-if-outside-if", E, "END IF without an open IF.",
         "The device refuses an END_IF outside an IF block.", "Remove it or add its IF.",
         "download error 0x04"),
    Rule("E309", "if-not-closed", E, "IF without END IF.",
         "Every IF must be closed by END IF inside the same program.", "Add END IF.",
         "download error 0x05"),
    Rule("E310", "if-too-deep", E, "IF blocks nested deeper than the device allows.",
         "The M8194H allows one outer IF and six inner ones (7 levels); it is reported where "
         "the nesting first passes that. Beyond 64 levels of blocks the compiler stops "
         "following: that block is reported too and its lines are not compiled.",
         "Flatten the conditions, or move the inner part into a called MP.",
         "download error 0x02"),
    Rule("E311", "for-too-deep", E, "FOR loops nested deeper than the device allows.",
         "The M8194H allows one outer loop and six inner ones (7 levels); it is reported where "
         "the nesting first passes that. Beyond 64 levels of blocks the compiler stops "
         "following: that loop is reported too and its lines are not compiled.",
         "Flatten the loops, or move the inner part into a called MP.",
         "download error 0x07"),
    Rule("E312", "nested-program", E, "An MP or ISR header inside another program.",
         "Programs cannot be nested.", "Close the first program with END MP/END ISR."),
    Rule("E313", "block-in-isr", E, "FOR loops are not allowed in an ISR.",
         "ISRs must finish quickly; the device accepts no MP_FOR in an ISR table.",
         "Move the loop into an MP.", "ERR_MP_INSIDE_ISR (register 102 cause 0x05)"),
    # ------------------------------------------------------------------------- labels
    Rule("E314", "loop-not-closed", E, "WHILE without END WHILE, or REPEAT without END REPEAT.",
         "Every WHILE and REPEAT must be closed inside the same program.",
         "Add END WHILE / END REPEAT."),
    Rule("E315", "end-loop-without-loop", E, "END WHILE or END REPEAT without its loop.",
         "An END WHILE / END REPEAT must close an open WHILE / REPEAT.",
         "Remove it, or add its WHILE / REPEAT."),
    Rule("E328", "while-placement", E, "A WHILE loop where the device cannot have its label.",
         "WHILE lowers to LABEL, IF, the body, GOTO and END IF. The device allows labels only "
         "outside FOR and IF blocks and not in an ISR, so a WHILE must stand at the top level "
         "of an MP.",
         "Put the loop at the top level of an MP: an MP of its own, CALLed from inside the "
         "block, works anywhere; or use FOR with EXIT FOR."),
    Rule("E329", "loop-needs-label", E, "A WHILE loop finds no free label.",
         "Each WHILE takes one of the program's four labels (LABEL 0..3).",
         "Free a label, or move the loop into an MP of its own and CALL it."),
    Rule("E321", "too-many-labels", E, "More than four labels in one program.",
         "Each macro table has four labels, numbered 0 to 3.",
         "Reuse labels, or split the program into called MPs."),
    Rule("E322", "duplicate-label", E, "A label is defined twice in one program.",
         "Each label number may be defined once per table; several GOTOs may jump to it.",
         "Rename one of the labels.", "download error 0x0B"),
    Rule("E323", "label-inside-if", E, "A LABEL inside an IF block.",
         "Jumping into an IF block is not allowed; jumping out of one is.",
         "Move the LABEL outside the IF.", "download error 0x0C"),
    Rule("E324", "label-inside-for", E, "A LABEL inside a FOR loop.",
         "Jumping into a loop is not allowed; jumping out of one is.",
         "Move the LABEL outside the FOR.", "download error 0x0D"),
    Rule("E325", "goto-without-label", E, "GOTO to a label not defined in this program.",
         "Jumps stay within one program.", "Define the LABEL in the same program.",
         "download error 0x0E"),
    Rule("E326", "label-number", E, "A numeric label outside 0..3.",
         "The device numbers labels 0 to 3.", "Use 0..3, or a name."),
    Rule("E327", "label-in-isr", E, "LABEL/GOTO inside an ISR.",
         "The manual forbids GOTO and LABEL in ISR tables.",
         "Use IF blocks in the ISR, or do the work in an MP.",
         "ERR_MP_INSIDE_ISR (register 102 cause 0x05)"),
    # ------------------------------------------------------------------- command scope
    Rule("E401", "rtc-only-command", E, "A real-time (RTC) command inside a program.",
         "RTC commands are executed immediately by the host API and cannot be stored in a "
         "macro table.", "Use the macro form of the command if it has one.",
         "ERR_RTC_INSIDE_MP_OR_ISR (register 102 cause 0x07)"),
    Rule("E402", "not-allowed-in-isr", E, "A command the device does not accept in an ISR.",
         "Only commands marked for ISR in the manual's Table 1 may be stored in an ISR.",
         "Do this in an MP, or start an MP from the ISR's caller.",
         "ERR_MP_INSIDE_ISR (register 102 cause 0x05)"),
    Rule("E403", "not-allowed-in-mp", E, "An ISR-only command inside an MP.",
         "The command is only accepted in an ISR table.", "Move it into an ISR.",
         "ERR_ISR_INSIDE_MP (register 102 cause 0x06)"),
    Rule("E404", "not-on-target", E, "The command does not exist on the selected controller.",
         "Some commands exist only on the RS-M8194H (for example INTP_END).",
         "Build with --target rs, or avoid the command."),
    Rule("E405", "not-a-macro-command", E, "The function has no macro command form.",
         "Register reads and DLL-side functions cannot be stored in a program.",
         "Use the value-returning macro reads (GET_LP, GET_EP, ...) with an assignment."),
    Rule("E406", "explicit-close", E, "MP_CLOSE/MP_ISR_CLOSE written inside a program.",
         "END MP/END ISR generates the close; a close in the middle would end the table.",
         "Use EXIT to leave early; remove the close."),
    # ------------------------------------------------------------------------ arguments
    Rule("E411", "argument-count", E, "Wrong number of arguments.",
         "Arguments follow the C API order after the handle and slave address.",
         "See the command's parameters in docs/commands.md."),
    Rule("E412", "argument-range", E, "An argument is outside its documented range.",
         "The manual gives each parameter's range; the device answers out-of-range values "
         "with an exception.", "Use a value inside the range.",
         "parameter out of range (register 102 cause 0x02)"),
    Rule("E413", "axis-code", E, "An axis argument is not valid for this parameter.",
         "Some parameters take one axis only (X, Y, Z or U); the initial-table codes "
         "(INITIAL_*) cannot be used in a program.", "Use a valid axis name."),
    Rule("E414", "variable-not-allowed", E, "A variable where the device needs a constant.",
         "A 16-bit parameter (BYTE/WORD) cannot carry the 32-bit variable reference.",
         "Use a constant (CONST) here."),
    Rule("E415", "variable-required", E, "A constant where the command needs a variable.",
         "The parameter names a variable to write (a result), not a value.",
         "Pass VARn or an ALIAS."),
    Rule("E416", "argument-type", E, "An argument of the wrong kind.",
         "For example a string where a number is expected, or an expression that is not "
         "constant in a command argument.",
         "Compute the value into a VAR first, or use a constant."),
    Rule("E417", "not-an-allowed-value", E, "A value the parameter does not accept.",
         "The parameter takes only the values the manual lists.",
         "Use one of the listed values or their symbolic names."),
    Rule("E418", "immediate-range", E, "A constant beyond +/-2,000,000,000.",
         "Immediate operands are limited to +/-2,000,000,000 so that they never look like a "
         "variable reference (0x7FFF0000 + n).", "Use a smaller value."),
    # --------------------------------------------------------------------- expressions
    Rule("E421", "query-misuse", E, "A value-returning read is used where it cannot return.",
         "Reads such as GET_LP(X) can only feed an assignment: VAR5 = GET_LP(X).",
         "Assign the read to a variable first."),
    Rule("E422", "temporaries-exhausted", E,
         "An expression needs more temporaries than the pool has.",
         "Nested expressions are computed through compiler temporary variables.",
         "Split the expression, or widen the pool with --temp-vars."),
    Rule("E423", "assign-target", E, "The left side of '=' is not a variable.",
         "Assignments write a device variable VARn (or its ALIAS).", "Assign to VARn."),
    Rule("E424", "bad-operator", E, "An operator the device cannot compute.",
         "VAR_CALCULATE knows + - * / & | and IF knows < > <= >= == !=.",
         "Rewrite the expression with those operators."),
    # ------------------------------------------------------------------------- calls
    Rule("E431", "call-target", E, "CALL names something that is not an MP.",
         "MP_CALL starts an MP program (MP1..MP157); ISRs are started by interrupts.",
         "CALL an MP by number or by name."),
    Rule("E432", "call-recursion", E, "Programs call each other in a cycle.",
         "The device has no recursion: a cycle of MP_CALLs would overflow its call stack.",
         "Break the cycle, for example with a loop."),
    Rule("E433", "call-too-deep", E, "MP_CALL chain deeper than the device allows.",
         "An MP may call nested programs up to 7 levels (the caller and six nested calls).",
         "Flatten the call chain."),
    Rule("E434", "unknown-program", E, "CALL names a program not defined in this build.",
         "A program name is only known if the program is part of the build.",
         "Add the file defining it, or CALL it by slot number (MPn)."),
    # ------------------------------------------------------------------ E5: slots, link
    Rule("E501", "slot-range", E, "A program slot that does not exist.",
         "Slots are MP1..MP157 and ISR1..ISR20.", "Use an existing slot number."),
    Rule("E502", "duplicate-slot", E, "Two programs take the same slot.",
         "A slot holds one program.", "Give one of them another slot, or no number."),
    Rule("E503", "budget-exceeded", E, "A program has more lines than its slot provides.",
         "Each slot has a fixed number of macro lines; some commands take 2, 3 or 4 lines "
         "and the closing line counts.",
         "Move the program to a larger slot (or drop the number to let the linker choose), "
         "or split it into called MPs.", "download error 0x01"),
    Rule("E504", "no-slot-fits", E, "No free slot is large enough for an unnumbered program.",
         "The linker places unnumbered programs into the smallest free slot that fits.",
         "Free a slot or split the program."),
    Rule("E505", "duplicate-program-name", E, "Two programs have the same name.",
         "Program names are global to a build (CALL name must be unambiguous).",
         "Rename one of them."),
    Rule("E506", "slot-pin-conflict", E,
         "A slot pin in mpc.toml contradicts the program it pins.",
         "A pin (`name = \"MP3\"` in the project's [slots] table) must name a slot of the "
         "program's kind, and may not disagree with a number written in the source.",
         "Keep either the number in the source or the pin, and pin MPs to MP slots."),
    # --------------------------------------------------------------------- warnings
    Rule("W101", "unreachable-code", W, "Code after GOTO, EXIT or TERMINATE that nothing reaches.",
         "Statements after an unconditional jump in the same block never run.",
         "Remove them, or add a LABEL before them."),
    Rule("W102", "loop-never-runs", W, "A FOR loop whose constant count is zero or negative.",
         "The device counts the loop down to zero, so the body never runs.",
         "Use a positive count."),
    Rule("W103", "read-before-write", W, "A variable is read before this program writes it.",
         "Variables are volatile; unless the host or another program sets it first, the "
         "value is whatever was left there.",
         "Initialise the variable in this program, or ignore if the host sets it."),
    Rule("W104", "temporary-touched", W, "User code uses a compiler temporary variable.",
         "Expressions are computed through the temporary pool; its values change behind "
         "your back.", "Use a variable outside the pool, or move the pool with --temp-vars."),
    Rule("W105", "call-outside-build", W, "CALL to an MP that is not part of this build.",
         "The program may already be on the device; the compiler cannot check it.",
         "Make sure the slot is programmed, or add its source to the build."),
    Rule("W106", "rvar-without-read", W, "SET_RVAR with no value-returning read before it.",
         "SET_RVAR stores the result of the preceding read (GET_LP, FRNET_IN, ...).",
         "Put the read right before it, or write VARn = GET_LP(X)."),
    Rule("W108", "ambiguous-immediate", W,
         "An immediate that the device would read as a variable reference.",
         "FRNET_OUT sends a variable as its holding-register address 300 + 2n, so an output "
         "pattern 300..1322 (even) looks exactly like VARn on the wire.",
         "Put the pattern in a variable first: VARn = pattern, then FRNET_OUT group, VARn."),
    Rule("W110", "constant-wraps", W, "A constant expression overflows 32 bits and wraps.",
         "VAR_CALCULATE computes in 32 bits and wraps around (2000000000 + 2000000000 is "
         "-294967296 on the device); the compiler folds constant expressions the same way, "
         "so the program does what the device would do, but an overflow is rarely meant.",
         "Write the wrapped value if the wrap is intended; otherwise scale the numbers down."),
    Rule("W111", "device-steps-value", W,
         "A constant speed, acceleration or jerk that the device will clamp or step.",
         "The motion chip holds these settings in units of its maximum speed MAX_V: a speed "
         "is at most MAX_V and a multiple of MAX_V/8000, an acceleration a multiple of "
         "MAX_V/64 between MAX_V/64 and MAX_V*125, a jerk at least MAX_V*0.0119211 (RS "
         "1146, 5157, 5257; profile [chip_values]). The device runs the value it holds, and "
         "so does the virtual controller: a ramp, a cycle time, differ from the value "
         "written. The compiler reads MAX_V from the INIT block (or the factory 200000) and "
         "the program's own SET_MAX_V lines above, in source order.",
         "Write the value the warning gives, or change MAX_V so that the value is a step."),
    Rule("W109", "unused-slot-pin", W, "A slot pin in mpc.toml names no program of the build.",
         "The pin has no effect; perhaps the program was renamed or its file left out.",
         "Remove the pin or fix the name."),
    Rule("W107", "undocumented-variable", W,
         "A variable passed where the manual does not document variables.",
         "The manual documents VARn operands only for some parameters; the 32-bit "
         "encoding is accepted, but the firmware's handling is not described.",
         "Prefer a constant, or test on the device."),
    # ------------------------------------ E8/W8: whole-controller configuration blocks
    Rule("E802", "config-block-content", E,
         "A line that does not belong in an INIT, INTERRUPTS or TRIGGERS block.",
         "INIT holds only initial-table commands, INTERRUPTS only `ON axis factor CALL isr` "
         "lines and TRIGGERS only `ON DI g.c condition event` lines; `ON DI` lines exist only "
         "in a TRIGGERS block and `ON axis` lines only in an INTERRUPTS block or a program.",
         "Move the line into a program, or into the block it belongs to."),
    Rule("E805", "config-block-structure", E,
         "An INIT, INTERRUPTS or TRIGGERS block is nested, not closed, or closed twice.",
         "Configuration blocks stand at the top level, between programs, and end with "
         "END INIT, END INTERRUPTS or END TRIGGERS.",
         "Close the open program first, and end the block with its END line."),
    Rule("E801", "init-duplicate", E, "More than one INIT block in a build.",
         "A controller has one initial table; two blocks would leave it to file order which "
         "setting wins.", "Merge the blocks into one."),
    Rule("E803", "init-command", E, "A command that cannot write the initial table.",
         "Only the commands Table 1 marks IT write the initial table (pulse mode, maximum "
         "speed, limits, home levels, software limits, encoder, servo, alarm, in-position, "
         "filter, ring counter, triangle prevention, external drive off); they are sent as "
         "real-time commands with an INITIAL_* axis code.",
         "Set it from a program or the host instead; see docs/configuration.md for the list.",
         device="illegal function cause 3 (no such command)"),
    Rule("E804", "init-variable", E, "A variable as an initial-table value.",
         "The initial table is stored in the controller's non-volatile memory when the block "
         "is downloaded; it holds numbers, not references to variables that change later.",
         "Use a constant (CONST) instead."),
    Rule("W801", "init-override", W, "An INIT line sets again what an earlier line set.",
         "Always the last setting is retained (chapter 8, RS 9726), so the earlier line has "
         "no effect on those axes.", "Remove the earlier line, or the later one."),
    Rule("E811", "interrupt-factor", E, "An interrupt factor the motion chip does not have.",
         "INTFACTOR_ENABLE takes the factors of Table 11: PULSE, P>=C-, P<C-, P<C+, P>=C+, "
         "C-END, C-STA, D-END (or their numbers 0-7).",
         "Write one of the factor names, without spaces (`P>=C+`)."),
    Rule("E812", "interrupt-target", E, "ON ... CALL names no ISR.",
         "An interrupt factor starts an interrupt routine: ISR1..ISR20, by number "
         "(`CALL ISR 3`) or by the name of an ISR of the build.",
         "Name an ISR; an MP cannot answer an interrupt."),
    Rule("E813", "interrupt-conflict", E, "One axis and factor wired to two ISRs.",
         "Each axis holds one ISR number per factor; a second INTFACTOR_ENABLE replaces the "
         "first, so one of the declarations would never take effect.",
         "Keep one ON line per axis and factor, or re-arm it from the ISR on purpose with an "
         "ON line inside the ISR."),
    Rule("E814", "interrupt-slmt-conflict", E,
         "A compare interrupt on an axis whose software limits are enabled.",
         "The software limits use the COMP+/COMP- registers that the factors P>=C-, P<C-, "
         "P<C+ and P>=C+ compare against; the manual says INTFACTOR_ENABLE 'is conflict with "
         "RSM_SET_SLMT' (RS 8027).",
         "Disable the software limits of that axis in INIT (CLEAR_SLMT), or clear them "
         "(CLEAR_SLMT) or set the compare value (SET_COMPARE) in the setup program first."),
    Rule("E815", "interrupt-setup-program", E,
         "INTERRUPTS names no MP of the build.",
         "The wiring is compiled into the setup program the block names; it must be an MP "
         "(ENABLE_INT exists only in MPs and in real time) built together with the block.",
         "Name an MP of the build by name or number (`INTERRUPTS MP 3`)."),
    Rule("W811", "interrupt-isr-missing", W, "An interrupt calls an ISR slot no program fills.",
         "An interrupt whose ISR slot is empty does nothing on the device.",
         "Build the ISR together with the wiring, or ignore if it is downloaded separately."),
    Rule("W812", "interrupt-no-compare", W,
         "A compare interrupt on an axis no program gives a compare value.",
         "P>=C-, P<C-, P<C+ and P>=C+ compare against COMP+/COMP-, which only SET_COMPARE "
         "sets; without it the factor compares with whatever the registers hold.",
         "Call SET_COMPARE for that axis in the setup program before the motion starts."),
    Rule("E821", "trigger-channel", E, "A DI channel outside the FRnet DI groups.",
         "Stand-alone triggers are FRnet DI channels: groups 8..15, channels 0..15.",
         "Write DI g.c with g in 8..15 and c in 0..15."),
    Rule("E822", "trigger-condition", E, "A trigger condition the controller does not define.",
         "The conditions are OFF, ON, ON_TO_OFF, OFF_TO_ON and CHANGE (chapter 10).",
         "Write one of those conditions; leave unused channels out."),
    Rule("E823", "trigger-event", E, "A trigger event the controller does not define.",
         "A DI event starts an MP (`CALL name` / `CALL MP 5`), aborts the running command "
         "(`ABORT COMMAND`) or macro program (`ABORT MACRO`), or holds the drive of some axes "
         "(`HOLD XY`).", "Write one of those events."),
    Rule("E824", "trigger-duplicate", E, "One DI channel with two trigger lines.",
         "The trigger table holds one condition and one event per channel.",
         "Keep one line per channel."),
    Rule("W821", "trigger-mp-missing", W, "A trigger starts an MP slot no program fills.",
         "Triggering an empty MP does nothing on the device.",
         "Build the MP together with the table, or ignore if it is downloaded separately."),
    # ------------------------------------------ FATEK FBs-PLC positioning programs (E6xx/W6xx)
    Rule("E601", "fbs-syntax", E, "A line of an FBs-PLC listing does not follow its syntax.",
         "A listing line is a step instruction (SPD, DRV, DRVC, DRVZ, LIN, LINE, WAIT, ACT, "
         "EXT, GOTO, MEND; a step starts with its number), a TABLE header, a FUN141 parameter "
         "'Pn = value' or a SIM line, with the operands the manual prints (FB 863-1149, "
         "2181-2389).",
         "Compare the line with the forms in docs/fatek.md."),
    Rule("E602", "fbs-step-number", E, "Steps are not numbered 1, 2, 3, ... in order.",
         "The PLC stores steps by position (SR+2 onward, 9 or 15 registers each) and GOTO n "
         "means the n-th step; a step number that differs from its position would make GOTO "
         "jump somewhere else than it says.",
         "Renumber the steps 001, 002, ... in the order they appear."),
    Rule("E603", "fbs-step-count", E, "A table has no step, or more steps than the PLC allows.",
         "A FUN140 table holds 1-250 steps (FB 573, 686); more raise PLC error 36.",
         "Split the program into several tables.", "error 36 (more than the maximum steps)"),
    Rule("E604", "fbs-speed-range", E, "A constant SPD is outside the output frequency range.",
         "FUN140 outputs 1-921600 Hz (FB 883), FUN147 a line speed of 1-1840000 (FB 2191); "
         "SPD 0 makes the step wait for ever for a non-zero speed (FB 885-887).",
         "Use a speed inside the range, or a register the ladder sets.",
         "error 31 (speed value wrong)"),
    Rule("E605", "fbs-stroke-range", E, "A constant stroke is outside its range.",
         "DRV/DRVC strokes are -99999999..99999999 (FB 958); one LIN moves an axis at most "
         "1999999 Ps (FB 2261-2262).", "Split the move, or use a smaller unit.",
         "error 33 (stroke value wrong)"),
    Rule("E606", "fbs-register", E, "A variable operand names a register the PLC cannot use.",
         "Rxxxx/Dxxxx operands are read from PLC registers; a 32-bit operand (speed, stroke) "
         "takes the named register and the next one, and both must exist in one area "
         "(docs/fatek.md lists the areas).", "Use a register of the listed areas.",
         "error 30/32 (speed/stroke variable number wrong)"),
    Rule("E607", "fbs-contact-range", E, "A contact does not exist.",
         "WAIT and EXT wait for X0-X255, Y0-Y255, M0-M1911 or S0-S999 (FB 1087-1093).",
         "Use an existing contact."),
    Rule("E608", "fbs-goto-target", E, "GOTO names a step the table does not have.",
         "GOTO n jumps to step n of the same table (FB 1145).",
         "Jump to a step 1..N, or use GOTO NEXT.", "error 34 (illegal positioning program)"),
    Rule("E609", "fbs-drvc-abs", E, "ABS in a DRVC chain after its first segment.",
         "Only the first DRVC of a continuous multi-speed chain may use absolute coordinates "
         "(FB 975-977).", "Write the later segments with ADR.",
         "error 41 (ABS not allowed inside DRVC)"),
    Rule("E610", "fbs-direction", E, "A direction field the instruction does not take.",
         "DRVC needs + or - (FB 978); ABS takes no direction (FB 911-918); with + or - the "
         "stroke constant is unsigned (FB 891-898).",
         "Use + or - with DRVC, a blank direction with ABS, and let a signed stroke go with a "
         "blank direction."),
    Rule("E611", "fbs-drvc-chain", E, "A DRVC chain that does not end with a DRV, or is too long.",
         "A chain of n speeds is n-1 DRVC steps closed by one DRV step (FB 1013-1019), at most "
         "8 segments (FB 974).", "Close the chain with a DRV step; split chains longer than 8."),
    Rule("E612", "fbs-drvc-drvz", E, "DRVZ right after a DRVC.",
         "A DRVC chain cannot flow into a home return (FB 801).",
         "End the chain with a DRV step before the DRVZ.",
         "error 42 (DRVC cannot be followed by DRVZ)"),
    Rule("E613", "fbs-drvc-transition", E, "A DRVC step with a condition, MEND or a jump away.",
         "A DRVC segment flows straight into the next step (FB 988-997): it has no WAIT, ACT "
         "or EXT and goes on with GOTO NEXT.", "Write GOTO NEXT after the DRVC and nothing else."),
    Rule("E614", "fbs-instruction", E, "An instruction the table's function does not have.",
         "FUN140 has DRV, DRVC, DRVZ and ACT; FUN147 has LIN and LINE and no ACT (FB 474-490, "
         "2380).", "Use the instructions of the table's function, or change the table's kind.",
         "error 43 / 60 (drive command code wrong / illegal interpolation command)"),
    Rule("E615", "fbs-step-shape", E, "A step lacks a part, repeats one, or has them in disorder.",
         "A step holds its output speed, one motion and its transition (FB 571-575): SPD, "
         "then DRV/DRVC/DRVZ/LIN/LINE, then at most one WAIT/ACT/EXT, then GOTO or MEND.",
         "Give every step SPD, one motion and a GOTO or MEND, in that order.",
         "error 34 (illegal positioning program)"),
    Rule("E616", "fbs-table", E, "A table header the PLC cannot have.",
         "FUN140/FUN141 drive Ps0-Ps3, FUN147 groups Gp0-Gp1 (FB 525-529, 1846); a table and "
         "its work registers lie in R0-R3839, D0-D3999 or R5000-R8071 (FB 546-565); one "
         "FUN141 per axis (FB 1457); table names are unique.",
         "Fix the header; see docs/fatek.md."),
    Rule("E617", "fbs-register-overlap", E, "Two tables or work areas share registers.",
         "The registers of a program table must not be reused (FB 1159), nor the work "
         "registers of FUN140/FUN147 (FB 532-534, 1848-1850).",
         "Move one table (SR) or work area (WR)."),
    Rule("E618", "fbs-parameter", E, "A FUN141 parameter is outside its range.",
         "FUN141 checks every parameter and raises the code of the first bad one (FB "
         "1461-1503, 1526-1693).", "Use a value inside the parameter's range.",
         "FUN141 errors 1-15 (parameter n wrong)"),
    Rule("E619", "fbs-drvz-setup", E, "DRVZ without the FUN141 set-up its mode needs.",
         "DRVZ runs only with a correct FUN141 table (FB 3263-3267): a DOG input X0-X15, for "
         "MD2 a PG0 input X0-X15, a CLR output within Y0-Y23 if one is set (FB 3269-3298).",
         "Add the axis's FUN141 table with parameter 15, or fix the mode (MD0-MD2).",
         "errors 50-53 (DRVZ mode / DOG / PG0 / CLR wrong)"),
    Rule("E620", "fbs-time-range", E, "A WAIT/ACT time constant is outside 0..65535.",
         "Times are in 0.01 s (FB 1098, 1118); mplang reads a time as one 16-bit register "
         "(docs/device-choices.md).", "Use 0..65535, or a register."),
    Rule("W601", "fbs-undocumented-shape", W, "A step shape FB never prints.",
         "FB prints a bare GOTO only after DRVC, and MEND never after a condition; whether "
         "the PLC accepts other shapes is not stated.",
         "Write WAIT TIME,0 before a GOTO, and end with GOTO instead of a condition + MEND."),
    Rule("W602", "fbs-next-after-last", W, "GOTO NEXT in the last step.",
         "FB does not say where GOTO NEXT goes from the last step; the virtual controller wraps "
         "to step 1.", "Write GOTO 1 or MEND."),
    Rule("W603", "fbs-runs-for-ever", W, "A continuous run that nothing in the step can end.",
         "An ADR stroke of 0 runs without end (FB 955-957; ABS 0 is the position 0, FB 66, "
         "75) and LINE runs until its exit condition "
         "(FB 2299); WAIT is only checked after the output completes, so only EXT or ACT end "
         "such a step.", "Give the step EXT contact or ACT TIME, or a stroke."),
    Rule("W604", "fbs-speed-above-maximum", W, "A constant SPD above the axis's maximum speed.",
         "FUN141 parameter 4 is the highest output frequency (FB 1573-1581); the virtual "
         "controller caps the speed there.", "Lower SPD or raise parameter 4."),
    Rule("E640", "fatek-not-expressible", E, "An .mp command or block with no FBs-PLC counterpart.",
         "A positioning table holds speeds, single-axis or straight-line moves, waits on time "
         "and jumps; it has no arcs, outputs, interrupts, home sequences or calls to programs "
         "outside the build (docs/fatek.md lists the mapping).",
         "Leave it out of programs built for the FATEK targets, or write a native .fbs table."),
    Rule("E641", "fatek-runtime-decision", E, "A decision on a value known only at run time.",
         "The positioning language has no conditional branch and no counters (FB 1135-1147): "
         "IF, FOR and loops are evaluated at compile time, so their operands must be constants "
         "or variables with a known value.",
         "Make the condition or count a constant, or move the decision to the ladder."),
    Rule("E642", "fatek-runtime-value", E, "An operand computed at run time.",
         "Operands are constants or registers the ladder sets (FB 867-878); a value computed in "
         "the program (a position read, arithmetic on a host variable) has no register.",
         "Compute the value at compile time, or let the host write VARn and pass VARn itself."),
    Rule("E643", "fatek-axes", E, "Axes a FUN140 table cannot drive.",
         "A FUN140 table drives one axis (FB 122-124); interpolated and multi-axis moves need "
         "FUN147.", "Build with --target fbs-fun147, or split the program per axis."),
    Rule("E644", "fatek-wait-placement", E, "A wait where no step can hold it.",
         "A wait is the transition condition of a step, checked after that step's motion "
         "(FB 1095): a wait before the first move, or between a LABEL and the next move, has no "
         "step to belong to.", "Move the wait after a move."),
    Rule("E645", "fatek-table-size", E, "The program unrolls into too many steps.",
         "Loops are unrolled at compile time and a table holds at most 250 steps (FB 573).",
         "Use fewer iterations, or close the loop with LABEL/GOTO so it becomes a jump."),
    Rule("E647", "fatek-range", E, "A speed, stroke or time outside the PLC's ranges.",
         "SPD is 1-921600 (FUN147 1-1840000), a stroke at most 99999999 (LIN 1999999) and a "
         "time 0-65535 x 0.01 s (FB 883, 958, 2191, 2261).",
         "Use values inside the ranges; split long moves."),
    Rule("E648", "fatek-no-speed", E, "A move without a speed set before it.",
         "Every step carries its own SPD (FB 571-575); the compiler takes it from the last "
         "SET_V of the axis (SET_VV for LINE_2D/LINE_3D).",
         "Set the speed before the first move."),
    Rule("E649", "fatek-no-motion", E, "A program that makes no step.",
         "A positioning table has 1-250 steps (FB 686) and a step is a motion; a program "
         "without moves (and not only called by others) has no table.",
         "Add a move, or CALL the program from one that moves."),
    Rule("W640", "fatek-ignored", W, "An .mp command with no effect on an FBs-PLC table.",
         "It configures the M8194H's hardware or ramp shape; on the PLC that is the "
         "configuration, FUN141 or the ladder.",
         "Nothing to do if the motion is right; configure the PLC otherwise."),
    Rule("W641", "fatek-timing", W, "The PLC's timing will differ from the M8194H's.",
         "End positions are the same, but the PLC rounds waits to 0.01 s, starts WAIT TIME "
         "when the pulse output completes, ramps with one slope per axis (FUN141) and "
         "interpolates multi-axis moves.", "Check the timing on the machine if it matters."),
    Rule("W642", "fatek-zero-move", W, "A move of 0 pulses is left out.",
         "A stroke of 0 means a continuous run on the PLC (FB 955-957), so a zero move "
         "cannot be written; it moves nothing on the M8194H either.",
         "Remove the move, or make sure its distance is not 0."),
    # ------------------------------------------------------ CSIM RS232 command set (E7xx/W7xx)
    Rule("E701", "csim-syntax", E, "A CSIM line does not follow the command syntax.",
         "A CSIM line is a label ($NAME alone), a command with comma-separated operands, an "
         "assignment NAME=value or a ?query; `#` starts a comment (docs/csim.md).",
         "Compare the line with the command list in docs/csim.md."),
    Rule("E702", "csim-unknown-command", E, "A command or query is not in the CSIM list.",
         "Only the commands of the CSIM RS232 command list exist on the device.",
         "Use the suggested name, or look the command up in docs/csim.md."),
    Rule("E703", "csim-operand-count", E, "A CSIM command has the wrong number of operands.",
         "Each command takes the operands the manual lists.",
         "Give the operands the command's syntax shows."),
    Rule("E704", "csim-operand-type", E, "A CSIM operand is of the wrong kind.",
         "Operands are numbers, variables (Nn, Rn, NS(i), RS(i)), labels, outputs Pn or "
         "events EVn as each command demands; JE/JNE/JG/JNG compare values of one type, and "
         "functions are not documented.",
         "Write the kind of operand the command takes."),
    Rule("E705", "csim-operand-range", E, "A CSIM operand is outside its documented range.",
         "The manual gives ranges: inputs 1..8, outputs P1..P4, OUTP 0..15, FT 1..20000, "
         "TX..TW 0..5 or 8, integer variables up to 32766, CM 0..2 and more.",
         "Use a value inside the range."),
    Rule("E706", "csim-variable-range", E, "A CSIM variable does not exist.",
         "The CSIM has N0..N64, R0..R64 and the arrays NS(0..2000), RS(0..2000).",
         "Use an existing variable."),
    Rule("E707", "csim-module-prefix", E,
         "A module prefix Tp that does not exist or that the command does not take.",
         "Modules are T0..T7; single-module commands and parameters take the prefix, "
         "coordinated commands drive the logical axes and take none.",
         "Remove the prefix, or use T0..T7."),
    Rule("E708", "csim-undefined-label", E, "A jump, CALL or ON EV names a label that is not "
         "defined.", "A label is defined by a line holding only $NAME in the same program.",
         "Define the label, or fix its spelling."),
    Rule("E709", "csim-duplicate-label", E, "A CSIM label is defined twice.",
         "Every jump to the label would be ambiguous.", "Rename one of the labels."),
    Rule("E710", "csim-address-range", E, "A numeric jump address is past the program's end.",
         "Addresses count the program's lines from 0.",
         "Use a label instead of a number."),
    Rule("E711", "csim-wrong-context", E,
         "A host command stored in a program, or a program-only command sent from the host.",
         "The manual marks where each command may be used: editing, queries and G are host "
         "commands; jumps, waits and the variable forms of coordinated moves exist only in "
         "programs (CS 175).",
         "Move the command to where it may be used."),
    Rule("E712", "csim-unknown-parameter", E, "An assignment names no CSIM parameter or "
         "variable.", "NAME=value sets a system parameter (CS 142) or a variable.",
         "Use a parameter of the list in docs/csim.md, or a variable Nn/Rn."),
    Rule("W701", "csim-undocumented-arithmetic", W,
         "Arithmetic or an assignment from a variable, which the CSIM list does not document.",
         "The command list has only `N#=data` (CS 136); the spelling `V=a op b` is mplang's "
         "reading and may differ on the device.",
         "Check the line on the device; silence with `# mpc: ignore[W701]` once verified."),
    Rule("W702", "csim-not-modelled", W, "A command the virtual CSIM cannot execute.",
         "Its behaviour is not described well enough to simulate (for example SPI, FT, PWM, "
         "position-synchronised outputs); mpc run stops there with an error.",
         "Test the program on the device."),
    Rule("W703", "csim-undocumented-parameter", W,
         "A PNn/PRn parameter that the CSIM list does not describe.",
         "The virtual CSIM stores it but it has no effect there.",
         "Check the parameter in the drive's own manual."),
    Rule("W704", "csim-unreachable", W, "A CSIM line after JP or RET that nothing reaches.",
         "Lines after an unconditional jump or return run only if a label leads to them.",
         "Remove them, or add a label before them."),
    Rule("E721", "csim-target-command", E, "An .mp command that the CSIM cannot express.",
         "The CSIM command set has no counterpart (FRnet, position reads, compare, "
         "synchronous actions, interrupts, continuous interpolation, ...).",
         "Leave the command out of programs built for --target csim, or rewrite it with "
         "what CSIM has (docs/csim.md lists the mapping)."),
    Rule("E722", "csim-target-form", E, "An .mp command form that the CSIM cannot express.",
         "The command exists but not in this form: homing and jogging only on X (T0), "
         "interpolation only on X,Y(,Z) in that order, no integer division or bit operators "
         "on CSIM reals, no variable where the CSIM form takes a number.",
         "Rewrite the line as docs/csim.md describes."),
    Rule("E723", "csim-target-variables", E, "More .mp variables than the CSIM has R variables.",
         "Every VARn used becomes one of R0..R64, counters of FOR loops too.",
         "Use fewer variables."),
    Rule("E724", "csim-target-program", E, "An .mp program that cannot become CSIM code.",
         "ISRs have no CSIM counterpart (events are SET EV/ON EV), and a CSIM holds one "
         "program: a CALL must reach a program of the same build.",
         "Build the ISR's work into an MP, and build every called program together."),
    Rule("W721", "csim-target-dropped", W, "An .mp command left out of the CSIM program.",
         "It only shapes the M8194H's profiles or configures its hardware; the CSIM has no "
         "such setting and the axes end in the same places without it.",
         "Nothing to do if that is fine; set the CSIM's own parameters otherwise."),
]

RULES: dict[str, Rule] = {rule.code: rule for rule in _RULES}
