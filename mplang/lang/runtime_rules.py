"""Every finding of a run on a virtual controller (`mpc run`, `mpc plot`), with its stable code.

The run-time counterpart of `rules.py`: codes never change meaning once published, and
`docs/runtime/<CODE>.md` is generated from this table (`python -m mplang.tools.docgen`). `device`
says what the controller itself shows for it (the execution error of registers 115-119, an
axis's error code), so a user can match a finding with what a real device reports.
"""

from __future__ import annotations

from mplang.lang.rules import Rule
from mplang.lang.severity import Severity

E = Severity.ERROR
W = Severity.WARNING

_RULES = [
    # ------------------------------------------------ R1: execution errors (registers 115-119)
    Rule("R101", "call-depth", E, "An MP_CALL nests more programs than the device allows.",
         "The controller keeps a short stack of called programs; one call too many stops "
         "every program with an execution error.",
         "Return from a program before calling deeper, or flatten the calls; a program that "
         "calls itself needs an end condition.",
         "execution error 0x01 in registers 115-119"),
    Rule("R102", "call-empty-slot", E, "An MP_CALL names a slot that holds no program.",
         "The called number is computed or was not downloaded with the build.",
         "Build and download the called program, or fix the number the call computes.",
         "execution error 0x02 in registers 115-119"),
    Rule("R103", "division-by-zero", E, "A VAR_CALCULATE divides by zero (/ or %).",
         "The divisor is a variable that holds 0 when the line runs.",
         "Test the divisor before dividing (IF VARn <> 0 ...).",
         "execution error 0x03 in registers 115-119"),
    Rule("R104", "not-executable", E, "A line's values make no sense to the device when it runs.",
         "A variable argument holds a value outside the command's range (an axis mask of 0, "
         "a direction of 7, a negative speed), which the compiler could not see.",
         "Check the values the variables hold at that line (mpc run --json shows them).",
         "execution error 0x04 in registers 115-119"),
    # ------------------------------------------------ R2: runs that do not end
    Rule("R201", "waits-for-ever", E, "A wait can never end: nothing it waits for will happen.",
         "STOP_WAIT on an axis whose motion never stops, or FRNET_WAIT for an input that "
         "nothing changes on the virtual machine (no limit switch, no sensor, no host).",
         "Give the wait something to wait for (a move that ends, a timeout), or run on a "
         "machine that has the sensor."),
    Rule("R202", "out-of-time", E, "The run did not finish within --max-time of simulated time.",
         "The program loops for ever, or simply takes longer than the limit.",
         "Give the loop an end, or raise --max-time."),
    # ------------------------------------------------ R3: what the virtual controller does not do
    Rule("R301", "not-modelled", W, "A command ran that the virtual controller does not simulate.",
         "It ran with no effect, so what follows may differ from a real machine.",
         "Nothing to do if that is fine; check the run on the machine otherwise."),
    # ------------------------------------------------ R31: axes stopped by the machine
    Rule("R311", "hardware-limit-stop", W, "An axis stopped on a hardware limit switch.",
         "The axis ran into LMT+ or LMT-. The device stops that axis and latches the cause in "
         "its error code; the program runs on. Homing routines that use the limit switch "
         "as their home switch meet it on purpose.",
         "Check the move's target and the direction of the search; clear the error with "
         "CLEAR_ERROR before the next move if the program goes on.",
         "error code bits 4/8 (LMT+/LMT-) of the axis (GET_ERROR_CODE, registers 20-23)"),
    Rule("R312", "software-limit-stop", W, "An axis stopped on its software limit.",
         "The move would have passed the software limit set with SET_SLMT.",
         "Keep the move inside the limits, or set the limits the machine really has.",
         "error code bits 1/2 (SLMT+/SLMT-) of the axis"),
    Rule("R313", "alarm-stop", W, "An axis stopped because its servo drive raised ALARM.",
         "The drive reports a fault; with SET_ALARM enabled the device stops that axis.",
         "Find the drive's fault; the axis refuses new moves while the alarm is active.",
         "error code bit 16 (ALARM) of the axis"),
    Rule("R314", "emergency-stop", W, "The axes stopped on an emergency stop.",
         "The EMG input was asserted, or a program or the host sent EMERGENCY_STOP. Every "
         "axis stops and new motion is refused until the emergency is cleared.",
         "Clear the cause, then CLEAR_EMERGENCY_STOP (software) or release EMG.",
         "error code bit 32 (EMG) or 512 (software emergency) of every axis"),
    Rule("R315", "home-search-failed", W, "A home search ended with the HOME error.",
         "The search did not find what it looks for (the home switch, the Z pulse) where the "
         "machine was, or it met a limit first.",
         "Run it on a machine that has the sensor (a simulated machine needs it configured), "
         "or check the search direction and the sensor wiring.",
         "error code bit 128 (HOME) of the axis"),
    Rule("R309", "internal-fault", E, "The virtual controller failed on a line.",
         "A fault of the simulator itself, not of the program: it stopped the programs as "
         "the device stops on an execution error.",
         "Report it with the program; the run up to that line is still shown.",
         "execution error 0x04 in registers 115-119"),
    # ------------------------------------------------ R4: the other families
    Rule("R401", "family-run-error", E, "A FATEK or CSIM program stopped with an error.",
         "The family's virtual controller met a step or line it cannot execute (a jump to "
         "nowhere, a value out of range, a limit), as the PLC or drive would.",
         "Read the message: it names the step or line and the value at fault."),
]

RUNTIME_RULES: dict[str, Rule] = {rule.code: rule for rule in _RULES}
