"""Every check the compiler makes, with its stable code.

Codes never change meaning once published; `docs/checks/<CODE>.md` is generated from this
table (`python -m mplang.docgen`) and a test keeps the two in step. `device` names the
controller's own download error or illegal-function cause the rule prevents, if any.
"""

from __future__ import annotations

from dataclasses import dataclass

from mplang.diagnostics import Severity

E = Severity.ERROR
W = Severity.WARNING


@dataclass(frozen=True)
class Rule:
    code: str
    name: str
    severity: Severity
    summary: str
    why: str
    fix: str
    device: str = ""


_RULES = [
    # ------------------------------------------------------------------ E1: reading sources
    Rule("E101", "syntax-error", E, "A line does not follow the statement syntax.",
         "Each line holds one statement: a declaration, a program header, a block keyword, an "
         "assignment or a command with comma-separated arguments.",
         "Compare the line with the statement forms in docs/language.md."),
    Rule("E102", "include-not-found", E, "An INCLUDE names a file that cannot be read.",
         "INCLUDE paths are resolved relative to the including file.",
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
         "The M8194H allows one outer IF and six inner ones (7 levels).",
         "Flatten the conditions, or move the inner part into a called MP.",
         "download error 0x02"),
    Rule("E311", "for-too-deep", E, "FOR loops nested deeper than the device allows.",
         "The M8194H allows one outer loop and six inner ones (7 levels).",
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
    Rule("W109", "unused-slot-pin", W, "A slot pin in mpc.toml names no program of the build.",
         "The pin has no effect; perhaps the program was renamed or its file left out.",
         "Remove the pin or fix the name."),
    Rule("W107", "undocumented-variable", W,
         "A variable passed where the manual does not document variables.",
         "The manual documents VARn operands only for some parameters; the 32-bit "
         "encoding is accepted, but the firmware's handling is not described.",
         "Prefer a constant, or test on the device."),
    # ------------------------------------------ FATEK FBs-PLC positioning programs (E6xx/W6xx)
    # ------------------------------------------------------ CSIM RS232 command set (E7xx/W7xx)
]

RULES: dict[str, Rule] = {rule.code: rule for rule in _RULES}
