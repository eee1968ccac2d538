"""The M8194H registers and codes a flash reads and writes (ET 6801-6835, appendix
12.1.12-12.1.13), in one place because the download (`flasher`) and the dry-run plan (`plan`)
both name them.
"""

from __future__ import annotations

STATE_REGISTER = 100  # input: 0 ready, 1 MP download, 2 ISR download
CAUSE_REGISTER = 102  # input: cause of the last ILLEGAL FUNCTION
STATUS_FIRST, STATUS_COUNT = 110, 5  # input: MP no, ISR no, command, 0-based line, error
IDENTITY_FIRST, IDENTITY_COUNT = 81, 5  # input: module id, RSM firmware, i-8094H firmware
WORD_ORDER_REGISTER = 14  # holding: 0 MSW first, 1 LSW first
ILLEGAL_FUNCTION, DEVICE_BUSY = 0x01, 0x06
DPRAM_FULL = 0xC1  # register-102 cause that means "busy": the frame was not taken
STATES = {0: "ready", 1: "MP download", 2: "ISR download"}
STATE_SPAN = 20  # input 100-119: state, i-8094H state, cause, download and execution status
CALL_REGISTER = 8  # holding: reads the running MP's number, 0 if none (device.toml call_mp)
MACRO_RUNNING = 0xC3  # register-102 cause: a macro program is running


def state_name(value: int) -> str:
    """Register 100 in words, also for a value the manual does not give."""
    return STATES.get(value, f"unknown state {value}")
CHIP_STATE_REGISTER = 101  # input: 4 loading the initial table, 5 initialization finished
CHIP_LOADING, CHIP_INITIALIZED = 4, 5
TRIGGER_REGISTER = 9  # holding: FRnet DI triggering 0 off / 1 on (5.4)
