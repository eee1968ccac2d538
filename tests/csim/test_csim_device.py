"""The virtual CSIM's protocol, without a serial line (a fake clock drives time)."""

from __future__ import annotations

from mplang.csim.device import VirtualCsim


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def device() -> tuple[VirtualCsim, Clock]:
    clock = Clock()
    return VirtualCsim(clock=clock), clock


def statuses(csim: VirtualCsim, *lines: str) -> list[str]:
    return [csim.handle(line).status for line in lines]


def test_wire_format_echo_data_status() -> None:
    csim, _ = device()
    assert csim.wire("?PE", csim.handle("?PE")) == b"?PE\r\n0\r\nOK\r\n"
    assert csim.wire("FOO", csim.handle("FOO")).startswith(b"FOO\r\nERR 2 unknown command")


def test_program_edit_list_and_upload() -> None:
    csim, _ = device()
    assert statuses(csim, "PG", "MA 100", "$END", "JP $END", "") == ["OK"] * 5
    assert csim.handle("PL").data == ["0000  MA 100", "0001  $END", "0002  JP $END"]
    assert csim.handle("ULP").data == ["MA 100", "$END", "JP $END"]
    assert statuses(csim, "PE 0", "MA 200", "PI 1", "MR 5", "PD 3") == ["OK"] * 5
    assert csim.handle("ULP").data == ["MA 200", "MR 5", "$END"]
    assert statuses(csim, "PA", "RET", "") == ["OK"] * 3
    assert csim.handle("ULP").data == ["MA 200", "MR 5", "$END", "RET"]
    assert csim.handle("PD 9").status.startswith("ERR 9 no such line")


def test_edit_mode_refuses_bad_lines_and_reports_undefined_labels() -> None:
    csim, _ = device()
    replies = statuses(csim, "DLP", "MA 1,2", "?PE", "JP $MISSING", "")
    assert replies[0] == "OK"
    assert replies[1].startswith("ERR 3 bad operand")
    assert replies[2].startswith("ERR 5 not allowed here")
    assert replies[3] == "OK"
    assert replies[4].startswith("ERR 6 undefined label")
    assert csim.handle("ULP").data == ["JP $MISSING"]  # stored, so PE can mend it
    assert csim.handle("G").status.startswith("ERR 6")


def test_running_program_in_real_time() -> None:
    csim, clock = device()
    statuses(csim, "DLP", "VM=2000", "MA 10000", "DN", 'OUT "there"', "")
    assert csim.handle("G").status == "OK"
    clock.now = 2.0
    assert csim.handle("?ST").data == ["WAIT"]
    assert csim.handle("?PE").data == ["3798"]
    assert csim.handle("MA 5").status.startswith("ERR 4 busy")
    assert csim.handle("N7=3").status == "OK"  # variables may change (events)
    clock.now = 6.0
    assert csim.tick() == ["there"]
    assert csim.handle("?ST").data == ["IDLE"]
    assert csim.handle("?N7").data == ["3"]


def test_external_commands_while_running() -> None:
    csim, clock = device()
    statuses(csim, "PG", "TX=0", "TY=1", "2MA 5000,0", "DN", "")
    csim.handle("G")
    clock.now = 1.0
    assert csim.handle("TAPZ").status == "OK"
    clock.now = 1.5
    assert csim.handle("?ST").data == ["PAUSE"]
    assert csim.handle("XMA 3").status.startswith("ERR 4")
    assert csim.handle("TVM=2000").status == "OK"
    assert csim.handle("EXIT").status == "OK"
    assert csim.handle("TAREDO").status == "OK"
    clock.now = 10.0
    assert csim.handle("?PE").data == ["5000"]


def test_geti_takes_a_line_from_the_host() -> None:
    csim, clock = device()
    statuses(csim, "PG", "GETI N3", "OUT N3", "")
    csim.handle("G")
    clock.now = 0.1
    assert csim.handle("42").status == "OK"
    clock.now = 0.2
    assert csim.tick() == ["42"]


def test_immediate_motion_queries_and_parameters() -> None:
    csim, clock = device()
    assert statuses(csim, "T1MA 500", "T1PR2=20000") == ["OK", "OK"]
    clock.now = 5.0
    assert csim.handle("?T1PE").data == ["500"]
    assert csim.handle("JP 3").status.startswith("ERR 5")
    assert "T1PR2=20000" in csim.handle("ULC").data
    assert csim.handle("?VER").data == ["mplang virtual CSIM 1"]
    assert csim.handle("?LL").status.startswith("ERR 7")
    assert csim.handle("TX=1").status == "OK"
    assert csim.handle("T1MA 0").status.startswith("ERR 8 run error: T1 is logical axis X")


def test_preload_stores_a_program_as_a_download_would() -> None:
    csim, _ = device()
    assert csim.preload(["TX=0", "$TOP", "XMR 5", "JP $TOP"]) is None
    assert csim.handle("ULP").data == ["TX=0", "$TOP", "XMR 5", "JP $TOP"]
    assert csim.mode == "command"


def test_preload_names_the_first_refused_line_and_leaves_edit_mode() -> None:
    csim, _ = device()
    text, reply = csim.preload(["MA 1", "MA 1,2", "MA 3"]) or ("", None)
    assert text == "MA 1,2" and reply is not None and reply.status.startswith("ERR 3")
    assert csim.mode == "command"
    refused = csim.preload(["JP $NOWHERE"])
    assert refused is not None and refused[0] == "" and refused[1].status.startswith("ERR 6")


class CreepingClock(Clock):
    """A wall clock that moves on a little at every reading, as a real one does."""

    def __call__(self) -> float:
        self.now += 0.0003
        return self.now


def test_cs_22_27_a_jog_ends_where_mpc_run_ends_it_whatever_the_clock_reads() -> None:
    """JGF ... WT ... JG0: the program and its motions keep one clock from G on, so reading
    the wall clock again while answering G cannot start the jog earlier than the program."""
    clock = CreepingClock()
    csim = VirtualCsim(clock=clock, time_scale=50.0)
    statuses(csim, "DLP", "JGF", "WT 300", "JG0", "DN", "")
    clock.now = 1.0
    assert csim.handle("G").status == "OK"
    clock.now = 5.0
    assert csim.handle("?ST").data == ["IDLE"]
    # VM = 1000, PR2 = 10000: 0.1 s ramp (50 units), 0.201 s at speed, 0.1 s brake (50)
    assert csim.handle("?PE").data == ["301"]
