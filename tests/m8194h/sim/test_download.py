"""The virtual M8194H's download state machine (`mplang.m8194h.sim.download`), in process:
what input registers 100-102 and 110-114 say during and after a download (appendix tables
12 and 13, RS 11365-11379; 9.12, RS 10961-10974), the profile's other [download] choices,
what the memory file keeps, and what `mpc sim -v` is told. Expected values come from those
lines of the manual and from the choices in stdlib/m8194h/device.toml; the Modbus side of
the same rules is in tests/m8194h/test_device_refusals.py."""

from __future__ import annotations

from pathlib import Path

import pytest
from deviceframes import CLOSE, CREATE, CREATE_ISR, ISR_CLOSE, macro, variant

from mplang.ir.macro import VarRef
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.registers import RegisterMap
from mplang.m8194h.sim.service import MemoryFile

SET_VAR1 = macro("SET_VAR", VarRef(1), 1)
VAR512 = macro("SET_VAR", VarRef(512), 1)  # VAR0..VAR511 (RS 2394, 10144): cause 2
# register 101 (RS 11365): 6 downloading, 7 download finished, 8 an MP runs
DOWNLOADING, DOWNLOADED, MP_RUNNING = 6, 7, 8


def inputs(vc: VirtualController, address: int, count: int = 1) -> list[int]:
    """Input registers as FC4 reads them."""
    return RegisterMap(vc).read_input(address, count)


def download(vc: VirtualController, create: list[int], *lines: list[int]) -> list[int]:
    """Create, lines and the close; the causes each frame was answered with."""
    close = [CLOSE] if create[0] == CREATE else [ISR_CLOSE]
    return [vc.write_subfunction(frame) for frame in (create, *lines, close)]


def told(vc: VirtualController) -> list[str]:
    """What the device logged (`mpc sim -v`), without the time stamps."""
    return [entry.split(" s: ", 1)[1] for entry in vc.log]


def test_register_101_is_6_while_downloading_and_7_after_the_close() -> None:
    """"6- downloading MACRO commands ... 7- Macro download finished" (RS 11365), for a
    download that stored its program and for one that failed."""
    vc = VirtualController()
    assert vc.write_subfunction([CREATE, 41]) == 0
    assert inputs(vc, 100, 2) == [1, DOWNLOADING]
    assert vc.write_subfunction(SET_VAR1) == 0
    assert inputs(vc, 101) == [DOWNLOADING]
    assert vc.write_subfunction([CLOSE]) == 0
    assert inputs(vc, 100, 2) == [0, DOWNLOADED]
    assert vc.write_subfunction([CREATE_ISR, 3]) == 0
    assert inputs(vc, 100, 2) == [2, DOWNLOADING]
    assert vc.write_subfunction(VAR512) == 0x02
    assert inputs(vc, 100, 2) == [2, DOWNLOADING]  # a failed download goes on to its close
    assert vc.write_subfunction([ISR_CLOSE]) == 0
    assert inputs(vc, 100, 2) == [0, DOWNLOADED]


@pytest.mark.parametrize(("create", "what"), [
    ([CREATE, 0], "MP_CREATE"), ([CREATE, 158], "MP_CREATE"),  # MP1 ~ MP157 (RS 9833)
    ([CREATE_ISR, 0], "MP_ISR_CREATE"), ([CREATE_ISR, 21], "MP_ISR_CREATE"),  # RS 10025
])
def test_a_create_of_a_slot_that_does_not_exist_is_cause_2(create: list[int],
                                                           what: str) -> None:
    """The create's program number out of its range is "Parameter value is NOT within
    defined range" (RS 11366): no download opens, 110-114 keep the last download."""
    vc = VirtualController()
    assert download(vc, [CREATE, 1], SET_VAR1) == [0, 0, 0]
    assert vc.write_subfunction(create) == 0x02
    assert inputs(vc, 100, 3) == [0, DOWNLOADED, 0x02]
    assert inputs(vc, 110, 5) == [1, 0, 0, 0, 0]
    assert told(vc)[-1].startswith(f"refused: {what} ")
    assert vc.write_subfunction(SET_VAR1) == 0x08  # a macro line outside a download


def test_no_download_opens_while_a_program_runs() -> None:
    """Cause 0xC3 "A Macro program is currently being executed" (RS 11368) for an MP or ISR
    create while MP21 runs (device.toml busy_while_running): the program runs on, no
    download opens, and the next create after it ends is taken."""
    vc = VirtualController()
    assert download(vc, [CREATE, 21], macro("TIMER", 1000)) == [0, 0, 0]
    vc.call(21)
    for create in ([CREATE, 22], [CREATE_ISR, 3]):
        assert vc.write_subfunction(create) == 0xC3
        assert inputs(vc, 100, 3) == [0, MP_RUNNING, 0xC3]
    assert inputs(vc, 110, 5) == [21, 0, 0, 0, 0]
    vc.advance(2.0, until_idle=True)
    assert not vc.stack and vc.write_subfunction([CREATE, 22]) == 0


def test_the_close_of_a_download_failed_at_a_line_is_acknowledged_with_no_cause() -> None:
    """The refused line was answered with its cause; the close itself is right, so it is
    acknowledged and register 102 reads "0- no error" (RS 11366) while 110-114 name the
    refused line (RS 10961). The same with close_failure = "refused", which answers only
    a failure found at the close with an exception."""
    for vc in (VirtualController(), variant(close_failure="refused")):
        assert download(vc, [CREATE, 41], SET_VAR1, VAR512) == [0, 0, 0x02, 0]
        assert inputs(vc, 100, 3) == [0, DOWNLOADED, 0]
        assert inputs(vc, 110, 5) == [41, 0, VAR512[0], 1, 0x0F]
        assert ("mp", 41) not in vc.tables


def test_an_empty_write_names_no_command() -> None:
    """A write of no registers inside a download is "No such command" (cause 3, RS 11366)
    and fails the download with 0x0F; register 112 names the register after 8000
    (RS 11379), and there is none: 0."""
    vc = VirtualController()
    assert vc.write_subfunction([CREATE, 41]) == 0
    assert vc.write_subfunction([]) == 0x03
    assert vc.write_subfunction([CLOSE]) == 0
    assert inputs(vc, 110, 5) == [41, 0, 0, 0, 0x0F]


def test_status_numbers_since_power_on_keep_the_other_kinds_number() -> None:
    """status_numbers = "since-power-on": 110 and 111 each hold "the last downloaded
    Macro MP [ISR] program number since RS-M8194H power on" (RS 11377-11378), whatever the
    other kind did since, a failed download included; "last-download" (the default)
    zeroes the other kind's number (RS 10972, 'If no ISR Macro has been downloaded IsrNo
    will be zero')."""
    steps = [([CREATE, 3], [SET_VAR1]), ([CREATE_ISR, 2], [SET_VAR1]),
             ([CREATE, 5], [SET_VAR1]), ([CREATE_ISR, 4], [VAR512])]
    kept = variant(status_numbers="since-power-on")
    last = VirtualController()
    seen: list[tuple[list[int], list[int]]] = []
    for create, lines in steps:
        download(kept, create, *lines)
        download(last, create, *lines)
        seen.append((inputs(kept, 110, 5), inputs(last, 110, 5)))
    assert seen == [([3, 0, 0, 0, 0], [3, 0, 0, 0, 0]),
                    ([3, 2, 0, 0, 0], [0, 2, 0, 0, 0]),
                    ([5, 2, 0, 0, 0], [5, 0, 0, 0, 0]),
                    ([5, 4, VAR512[0], 0, 0x0F], [0, 4, VAR512[0], 0, 0x0F])]


def test_a_refused_line_ends_the_download_at_once_when_the_profile_says_so() -> None:
    """refused_line = "ends" with a line that breaks the structure (ELSE outside IF, 0xB2,
    RS 11368): the device is ready at once with 110-114 naming that line (0x03, RS 10974),
    the next line is a macro command outside a program (cause 8) and the close is ignored
    (RS 9886)."""
    vc = variant(refused_line="ends")
    assert download(vc, [CREATE, 41], SET_VAR1) == [0, 0, 0]
    assert vc.write_subfunction([CREATE, 41]) == 0
    assert vc.write_subfunction(SET_VAR1) == 0
    assert vc.write_subfunction(macro("ELSE")) == 0xB2
    assert inputs(vc, 100, 3) == [0, DOWNLOADED, 0xB2]
    assert inputs(vc, 110, 5) == [41, 0, macro("ELSE")[0], 1, 0x03]
    assert ("mp", 41) not in vc.tables
    assert vc.write_subfunction(SET_VAR1) == 0x08
    assert vc.write_subfunction([CLOSE]) == 0 and inputs(vc, 110, 5)[4] == 0x03


def test_an_unknown_download_setting_is_refused_with_the_values_it_takes() -> None:
    """A profile value this module does not know is never taken for one it does."""
    for setting, expected in (("status_numbers", "last-download, since-power-on"),
                              ("refused_line", "fails, ends")):
        vc = variant(**{setting: "sometimes"})
        with pytest.raises(ValueError) as caught:
            download(vc, [CREATE, 41], VAR512)
        assert str(caught.value) == (f"device profile [download] {setting} = 'sometimes': "
                                     f"expected one of {expected}")


def test_the_memory_file_follows_every_stored_and_emptied_slot(tmp_path: Path) -> None:
    """The FRAM keeps what the downloads left (`mpc sim --memory`): a stored program, a
    slot a failed download emptied (RS 10974: nothing of it is written), and each further
    program, as a controller powered on from the file finds them."""
    vc, path = VirtualController(), tmp_path / "fram.json"
    memory = MemoryFile(vc, path)

    def after_power_on() -> set[tuple[str, int]]:
        memory.flush()
        fresh = VirtualController()
        fresh.restore(path)
        return set(fresh.tables)

    download(vc, [CREATE, 21], SET_VAR1)
    assert after_power_on() == {("mp", 21)}
    download(vc, [CREATE, 21], VAR512)
    assert after_power_on() == set()
    download(vc, [CREATE, 22], SET_VAR1)
    download(vc, [CREATE_ISR, 3], SET_VAR1)
    assert after_power_on() == {("mp", 22), ("isr", 3)}
    download(vc, [CREATE, 23], SET_VAR1)
    assert after_power_on() == {("mp", 22), ("mp", 23), ("isr", 3)}


def test_mpc_sim_v_is_told_each_refusal_and_its_outcome() -> None:
    """What `mpc sim -v` prints for a refused create, a refused line, the failed close and
    a close outside a download (RS 9886), named as the manual names programs (MP41)."""
    vc = VirtualController()
    vc.write_subfunction([CREATE, 0])
    download(vc, [CREATE, 41], SET_VAR1, VAR512)
    vc.write_subfunction([CLOSE])
    assert told(vc) == [
        "refused: MP_CREATE mp_No: 0x0 is not one of the values it takes",
        "refused: SET_VAR varNo: VAR512 does not exist (VAR0..VAR511)",
        "MP41 line 1: frame refused (cause 0x02): the download fails",
        "MP41 not stored: download error 0x0f at line 1",
        "MP_CLOSE outside a download: ignored"]
