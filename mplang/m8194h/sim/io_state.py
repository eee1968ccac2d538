"""Codes, records and shared per-axis state of the virtual M8194H's axis I/O.

The manual's error-code bits, interrupt and synchronous-action factors and home-search state
codes; `AxisReport`, what the registers show for one axis; the per-axis configuration and
status records; and `_IOBase`, the state that every layer of `AxisIO` shares, with the
signal each input shows under the configured active levels.  The layers build on it in this
order: `interrupts`, `sync_actions`, `homing`, and `axis_io` on top.

Conventions and simplifications (manual = RS manual, "l.N" its line N)
--------------------------------------------------------------------
* Active levels (SET_HLMT, SET_NHOME, SET_HOME_EDGE, SET_ALARM, SET_ENCODER nZEdge; power
  on all low active, l.9672-9700): with ``AxisSensors.wiring = None`` (default) the machine
  is wired to match, an engaged sensor is active.  With ``wiring = 0/1`` an engaged sensor
  drives that level and a free one the other, and the input is active when the level equals
  the configured active level -- a wrong setting then shows as an input active everywhere
  except on the switch, as on a real machine.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from mplang.m8194h.sim.axes import AXES, _axis_index, _mask_axes
from mplang.m8194h.sim.builders import _Motion
from mplang.m8194h.sim.signals import AxisSensors, _Intervals, _Periodic, _Signal

if TYPE_CHECKING:
    from mplang.m8194h.sim.motion import MotionModel
    from mplang.m8194h.sim.scripted import TimedChange, Watch

_INF = math.inf

# GET_ERROR_CODE bits (l.3668-3681); bits 0-8 are also the stop causes of table 26
ERR_SOFT_LIMIT_PLUS = 1
ERR_SOFT_LIMIT_MINUS = 2
ERR_LIMIT_PLUS = 4
ERR_LIMIT_MINUS = 8
ERR_ALARM = 16
ERR_EMERGENCY = 32
ERR_HOME = 128
ERR_SOFT_STOP = 256
ERR_SOFT_EMG = 512

# interrupt factors nINT (Table 7 / Table 11) and the triggered-register indexes
INT_PULSE, INT_P_GE_CMINUS, INT_P_LT_CMINUS, INT_P_LT_CPLUS, INT_P_GE_CPLUS = 0, 1, 2, 3, 4
INT_C_END, INT_C_STA, INT_D_END, FACTOR_HMEND, FACTOR_SYNC = 5, 6, 7, 8, 9

# synchronous-action activation factors nSYNC (l.7016-7023)
SYNC_P_GE_CPLUS, SYNC_P_LT_CPLUS, SYNC_P_LT_CMINUS, SYNC_P_GE_CMINUS = 0x01, 0x02, 0x04, 0x08
SYNC_D_STA, SYNC_D_END, SYNC_IN3_UP, SYNC_IN3_DOWN = 0x10, 0x20, 0x40, 0x80

# GET_HOME_SEARCH_STATE codes (l.3528)
HOME_IDLE, HOME_STEP1, HOME_BACK_ON, HOME_BACK_OFF, HOME_STEP2 = 0, 3, 8, 12, 15
HOME_STEP3, HOME_STEP4 = 20, 25


@dataclass(frozen=True)
class AxisReport:
    """What the controller's registers show for one axis at one moment."""

    axis: int  # 0..3 = X, Y, Z, U
    time: float
    lp: int
    ep: int
    machine_position: int
    driving: bool
    di_status: int  # GET_DI_ALL / input register 16+axis / discrete inputs 128+16*axis
    di_signal: int  # GET_DI_SIGNAL_ALL / input register 88+axis / discrete inputs 256+8*axis
    error_code: int  # GET_ERROR_CODE / input register 20+axis
    stop_causes: int  # table 26, discrete inputs 192+16*axis (bit n = address offset n)
    stopped: bool  # input register 58+axis (1: stopped)
    servo_on: bool  # coil 128+axis
    emergency: bool  # software emergency state, input register 25
    home_state: int  # GET_HOME_SEARCH_STATE / input register 92+axis
    home_end: float | None  # when the last home search ended (HMEND)
    latch: int  # GET_LATCH / input registers 62+2*axis


@dataclass
class _Action:
    drv: int = 0
    latch: int = 0
    preset: int = 0
    out: int = 0
    intr: int = 0
    isrs: tuple[int, int, int, int] = (0, 0, 0, 0)


@dataclass
class _AxisConfig:
    hlmt_plus_level: int = 0
    hlmt_minus_level: int = 0
    limit_stop_slow: bool = False
    nhome_level: int = 0
    home_level: int = 0
    z_level: int = 0
    alarm_enabled: bool = False
    alarm_level: int = 0
    inpos_enabled: bool = False
    inpos_level: int = 0
    slmt: bool = False
    comp_plus: int = 100_000
    comp_minus: int = -100_000
    comp_ep: bool = False
    hv: int = 500
    home_limit: bool = False
    home_steps: tuple[int, int, int, int] = (0, 0, 0, 0)  # +1 / -1 / 0 skip
    home_offset: int = 0
    int_factors: dict[int, int] = field(default_factory=dict)  # nINT -> ISR number
    sync_factors: int = 0
    sync_targets: int = 0
    action: _Action | None = None
    preset: int = 0


@dataclass
class _HomeRun:
    axis: int
    state: int = HOME_IDLE
    motion: _Motion | None = None
    stopping: bool = False  # decelerating at the end of step 1


@dataclass
class _AxisStatus:
    latched: int = 0  # the error code's bits (read and written as `errors`)
    latch: int = 0
    servo_on: bool = False
    alarm_input: bool = False
    in3_level: int = 1  # IN3 is low active; an open input reads high
    mach_off: int = 0  # machine position - LP
    home: _HomeRun | None = None
    home_end: float | None = None
    raised: Callable[[int], None] | None = None  # told of newly latched bits (run reports)

    @property
    def errors(self) -> int:
        return self.latched

    @errors.setter
    def errors(self, value: int) -> None:
        """Every stop cause latches here, so a run can say where the program was when an
        axis stopped on a limit, an alarm or an emergency."""
        new = value & ~self.latched
        self.latched = value
        if new and self.raised is not None:
            self.raised(new)


@dataclass(order=True)
class _Event:
    time: float
    rank: int
    kind: str = field(compare=False)
    axis: int = field(compare=False)
    arg: int = field(compare=False, default=0)
    motion: _Motion | None = field(compare=False, default=None)


@dataclass
class _Request:
    time: float
    isr: int
    axis: int
    factor: int


def _axes(mask: int) -> tuple[int, ...]:
    return _mask_axes(mask)


def _one_axis(code: int) -> int:
    return _axis_index(code)


class _IOBase:
    """The state of one model's axis I/O, its settings and the signals of its inputs."""

    def __init__(self, model: MotionModel) -> None:
        self.model = model
        self.sensors = [AxisSensors() for _ in AXES]
        self.cfg = [_AxisConfig() for _ in AXES]
        self.status = [_AxisStatus() for _ in AXES]
        self.now = 0.0
        self.emergency = False  # software emergency state (EMERGENCY_STOP)
        self.emg_input = False
        self.int_enabled = False
        self.triggered = [0] * 10  # registers 130-139: axis masks
        self.requests: list[_Request] = []
        self._events: list[_Event] = []
        self._next = _INF
        self._exempt: list[_Motion] = []  # motions already stopping on a limit
        self._version = 0
        self._prediction: tuple[int, float | None] | None = None
        # `AxisIO._calm`, known until a setting it reads changes (`_changed`); None: unknown
        self._calm_known: bool | None = None
        # the machine file's script (`scripted`): timed changes, position conditions
        self.script: list[TimedChange] = []
        self.script_next = 0
        self.watches: list[Watch] = []
        self.watch_above: list[bool] = []
        self.inpos_forced: list[bool | None] = [None] * len(AXES)
        self.di_changes: list[tuple[float, int, int, int]] = []  # (t, group, mask, value)

    def _changed(self) -> None:
        """A setting that decides whether a motion can meet an I/O event (a sensor, an
        axis setting, interrupts, a home search, the machine's conditions) changed."""
        self._calm_known = None

    def _configure(self, axis_mask: int, now: float, **values: object) -> None:
        self.model.settle(now)
        for i in _axes(axis_mask):
            for name, value in values.items():
                setattr(self.cfg[i], name, value)
        self._changed()
        self.model._recompute()

    # --------------------------------------------------------------- signals and levels
    def _signal(self, i: int, kind: str) -> _Signal:
        sensors, cfg = self.sensors[i], self.cfg[i]
        sig: _Signal
        if kind == "lmt+":
            lp = sensors.limit_plus
            sig, level = _Intervals([] if lp is None else [(lp, None)]), cfg.hlmt_plus_level
        elif kind == "lmt-":
            lm = sensors.limit_minus
            sig, level = _Intervals([] if lm is None else [(None, lm)]), cfg.hlmt_minus_level
        elif kind in ("home", "nhome"):
            span = sensors.home if kind == "home" else sensors.near_home
            sig = _Intervals([] if span is None else [span])
            level = cfg.home_level if kind == "home" else cfg.nhome_level
        else:
            if sensors.index_period is None:
                sig = _Intervals([])
            else:
                sig = _Periodic(sensors.index_period, sensors.index_offset,
                                min(sensors.index_width, sensors.index_period))
            level = cfg.z_level
        if sensors.wiring is None or sensors.wiring == level:
            return sig
        return sig.complement()

    def _alarm_signal(self, i: int) -> bool:
        wiring = self.sensors[i].wiring
        asserted = self.status[i].alarm_input
        if wiring is None:
            return asserted
        return (wiring if asserted else 1 - wiring) == self.cfg[i].alarm_level

    def _alarm_active(self, i: int) -> bool:
        return self.cfg[i].alarm_enabled and self._alarm_signal(i)
