"""The flasher's verification of each program (`_verify`) and its final check after the
last one (`_final_check`), against a virtual M8194H whose answers are forged at the moment
they are read: input register 100 (0 ready, 1 MP download, 2 ISR download) and the download
status in input registers 110-114 (MP number, ISR number, command, 0-based slot line,
download error: appendix 12.1.12-12.1.13, wErrCode table 13). Every forged answer must end
in an unverified or rejected flash whose message says what the device showed, never in a
success."""

from __future__ import annotations

import asyncio
from collections.abc import Callable

import pytest
from test_flash import ARCS, ISR_JOB, WRITE_REGISTERS, build_of, device, endpoint, tcp_device

from mplang.m8194h.flash import FlashImage, FlashReport, flash, image_from_build
from mplang.m8194h.modbus_server import DeviceFace, PacketHook
from mplang.m8194h.sim.controller import VirtualController

READ_INPUT = 4
STATE = 100  # input register 100, the download state; the flasher reads 100-114 at once

# The state register's values as the virtual controller holds them (input register 100)
DOWNLOAD_STATES = {"mp": "MP download", "isr": "ISR download"}

Forge = Callable[[VirtualController, int], None]


def flash_forging(image: FlashImage, forge: Forge, packets: PacketHook | None = None,
                  ) -> tuple[FlashReport, DeviceFace]:
    """Flash `image` (one program); `forge(controller, n)` runs before the device answers
    the n-th read of input registers from 100 after that program's close frame: n = 1 is
    its verification, n = 2 the final check. `packets` sees the Modbus TCP frames."""
    close = image.programs[-1].frames[-1]
    reads = [0]
    armed = [False]
    face: DeviceFace

    def hook(function_code: int, address: int, values: list[int] | None) -> int | None:
        if function_code == WRITE_REGISTERS and values == close:
            armed[0] = True
        elif function_code == READ_INPUT and address == STATE and armed[0]:
            reads[0] += 1
            forge(face.controller, reads[0])
        return None

    face = device(interpose=hook)

    async def scenario() -> FlashReport:
        async with tcp_device(face, packets) as (_server, port):
            return await flash(image, endpoint(port))

    return asyncio.run(scenario()), face


def arcs() -> FlashImage:
    """MP41 of `ARCS`: SET_V on slot line 0 (job.mp:2), ARC_CW on lines 1-2 (x2, job.mp:3),
    FOR on line 3 (job.mp:4), the assignment, NEXT, and the close frame (END MP, job.mp:7)."""
    return image_from_build(build_of(ARCS))


def test_an_untouched_flash_reads_the_status_twice_and_succeeds() -> None:
    """The baseline the forgeries below depart from: verification and final check each read
    100-114 once, and the status is MP41's with no error."""
    seen: list[int] = []
    report, face = flash_forging(arcs(), lambda _controller, n: seen.append(n))
    assert report.ok and report.outcome == "verified", report.error
    assert seen == [1, 2]
    assert report.programs[0].download_status == [41, 0, 0, 0, 0]
    assert face.controller.state == "ready"


def test_an_isr_verifies_by_the_isr_number_in_register_111() -> None:
    """After an ISR download register 110 (MP number) reads 0 and 111 the ISR's number."""
    isr_only = image_from_build(build_of(ISR_JOB.split("MP 22")[0]))
    assert [p.label for p in isr_only.programs] == ["ISR7 on_edge"]
    report, _face = flash_forging(isr_only, lambda _controller, _n: None)
    assert report.ok, report.error
    assert report.programs[0].download_status == [0, 7, 0, 0, 0]


def test_a_status_for_another_program_is_refused_in_full_words() -> None:
    def forge(controller: VirtualController, n: int) -> None:
        if n == 1:
            controller.download_status = (40, 0, 0, 0, 0)

    report, _face = flash_forging(arcs(), forge)
    assert report.outcome == "unverified"
    assert report.error == ("MP41 arcs: the download status (input registers 110-114) is for "
                            "MP40/ISR0, not for this program")


def test_an_answer_no_request_waited_for_downloads_the_program_again() -> None:
    """The device's answer to the close frame arrives twice (same transaction id): the
    second is one no request waited for, so the device may have carried out a request twice
    and the verification does not vouch for the program; it is downloaded again."""
    close = b"\x00\x01\x02" + bytes([0x0C, 0xCA])  # FC16: one register, 2 bytes, 0x0CCA
    seen = {"close": 0, "doubled": 0}

    def double_the_close_answer(sending: bool, data: bytes) -> bytes:
        # a Modbus TCP frame: MBAP (7 bytes), then the function code
        if not sending and data[7:8] == b"\x10" and data.endswith(close):
            seen["close"] += 1
        elif sending and data[7:8] == b"\x10" and seen["close"] == 1 and not seen["doubled"]:
            seen["doubled"] = 1
            return data + data
        return data

    report, face = flash_forging(arcs(), lambda _controller, _n: None, double_the_close_answer)
    assert seen == {"close": 2, "doubled": 1}
    assert report.ok, report.error
    assert report.programs[0].downloads == 2
    assert ("MP41 arcs: an answer arrived that no request was waiting for (a delayed or "
            "duplicated request): the device may hold a line twice: downloading it again "
            "from its create frame") in report.notes
    assert face.controller.state == "ready"


@pytest.mark.parametrize("state", ["mp", "isr"])
def test_a_device_still_in_download_state_after_the_close_is_unverified(state: str) -> None:
    """Register 100 must read 0 (ready) after the close frame; 1 or 2 means the close did not
    take, whatever 110-114 say."""
    def forge(controller: VirtualController, n: int) -> None:
        if n == 1:
            controller.state = state

    report, _face = flash_forging(arcs(), forge)
    assert report.outcome == "unverified" and not report.ok
    assert (f"MP41 arcs: the device is in {DOWNLOAD_STATES[state]} state after the close "
            "frame") in str(report.error)
    assert report.where == "job.mp:7"  # END MP: the close frame
    assert report.programs[0].status == "unverified"


@pytest.mark.parametrize(("line", "error", "reason", "where"), [
    (0, 0x0F, "macro command not defined (not written to FRAM)", "job.mp:2"),
    (1, 0x01, "more command lines than the macro table provides", "job.mp:3"),
    (2, 0x02, "IF nested deeper than one outer and six inner levels", "job.mp:3"),
    (3, 0x07, "FOR nested deeper than the limit", "job.mp:4"),
    (9, 0x10, "wrong VAR_CALCULATE operator", "job.mp:7"),
    (0, 0x7F, "unknown download error", "job.mp:2"),
])
def test_a_download_error_names_its_reason_slot_line_command_and_source(
        line: int, error: int, reason: str, where: str) -> None:
    """wErrCode (register 114) non-zero refuses the program: the message gives the code, its
    reason from the profile's table 13 (or "unknown download error"), the slot line and the
    command register 112 names; the source place is the frame on that slot line (ARC_CW takes
    lines 1 and 2; lines past the program are the close frame's)."""
    image = arcs()
    arc_code = image.programs[0].frames[2][0]

    def forge(controller: VirtualController, n: int) -> None:
        if n == 1:
            controller.download_status = (41, 0, arc_code, line, error)

    report, _face = flash_forging(image, forge)
    assert report.outcome == "rejected" and not report.ok
    assert (f"MP41 arcs: the device refused the program: download error {error:#04x} "
            f"({reason}) at slot line {line} (ARC_CW)") in str(report.error)
    assert report.where == where
    assert report.programs[0].status == "rejected"
    assert report.programs[0].download_status == [41, 0, arc_code, line, error]


def test_a_download_error_on_a_command_not_in_the_catalogue_gives_its_code() -> None:
    """Register 112 may name a code the catalogue does not know: it is given in hex."""
    def forge(controller: VirtualController, n: int) -> None:
        if n == 1:
            controller.download_status = (41, 0, 0xFFFE, 1, 0x0E)

    report, _face = flash_forging(arcs(), forge)
    assert report.outcome == "rejected"
    assert ("download error 0x0e (GOTO without its LABEL) at slot line 1 (command 0xfffe)"
            in str(report.error))


@pytest.mark.parametrize("state", ["mp", "isr"])
def test_a_device_that_left_ready_after_verification_fails_the_final_check(
        state: str) -> None:
    """The final check holds register 100 as well as 110-114: a late create frame that
    reached the device after the last verification opens a download and leaves the status
    as it was."""
    def forge(controller: VirtualController, n: int) -> None:
        if n == 2:
            controller.state = state

    report, _face = flash_forging(arcs(), forge)
    assert report.outcome == "unverified" and not report.ok
    assert (f"after the last verification the device changed (input register 100: "
            f"{DOWNLOAD_STATES[state]}; 110-114: [41, 0, 0, 0, 0], verified as "
            "[41, 0, 0, 0, 0]): a delayed request reached it; flash again"
            ) in str(report.error)


@pytest.mark.parametrize("field", range(5))
def test_any_field_of_the_status_changed_after_verification_fails_the_final_check(
        field: int) -> None:
    """Each of registers 110-114 counts in the final check, the state staying ready."""
    def forge(controller: VirtualController, n: int) -> None:
        if n == 2:
            status = list(controller.download_status)
            status[field] += 1
            controller.download_status = tuple(status)  # type: ignore[assignment]

    report, _face = flash_forging(arcs(), forge)
    changed = [41, 0, 0, 0, 0]
    changed[field] += 1
    assert report.outcome == "unverified"
    assert (f"after the last verification the device changed (input register 100: ready; "
            f"110-114: {changed}, verified as [41, 0, 0, 0, 0]): a delayed request reached "
            "it; flash again") in str(report.error)
