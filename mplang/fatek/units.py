"""FUN141 parameters of one axis and the unit conversions they imply (FB 1526-1693).

Strokes written in Ut and speeds written in mechanical units become pulses and pulses per
second here, for the checker's range checks and for the virtual controller alike.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mplang.fatek.model import ParamTable
from mplang.fatek.profile import Profile

MOTOR_UNITS = 1
MECHANICAL_UNITS = 0


@dataclass(frozen=True)
class AxisParams:
    """Every FUN141 parameter of an axis: the table's values over the defaults."""

    profile: Profile
    values: dict[int, int] = field(default_factory=dict)

    @classmethod
    def of(cls, profile: Profile, table: ParamTable | None) -> AxisParams:
        values = {spec.number: spec.default for spec in profile.params}
        if table is not None:
            values.update({k: v for k, v in table.values.items() if k in values})
        return cls(profile, values)

    def __getitem__(self, number: int) -> int:
        return self.values[number]

    @property
    def unit_system(self) -> int:
        return self.values[0]

    @property
    def pulses_per_rev(self) -> int:
        """A: parameter 14 when set, parameter 1 otherwise (FB 1549-1552)."""
        return self.values[14] or self.values[1]

    @property
    def travel_per_rev(self) -> int:
        """B in um, mDeg or 0.1 mInch per revolution (FB 1552-1557)."""
        return self.values[2]

    def stroke_pulses(self, value: int, unit: str) -> int:
        """A stroke setting as pulses: Ps as written; Ut by parameters 0, 1, 2, 3."""
        if unit == "Ps":
            return value
        scale: int = 10 ** (3 - self.values[3])
        if self.unit_system == MOTOR_UNITS:
            return value * scale if self.profile.motor_ut_scaling == "param3" else value
        travel = value * scale  # in units of parameter 2 (um, mDeg, 0.1 mInch)
        return round(travel * self.pulses_per_rev / self.travel_per_rev)

    def speed_hz(self, value: float) -> float:
        """A speed setting (SPD, parameters 4, 5, 6) as pulses per second: in mechanical units
        f = V x 1000 x A / (6 x B) (FB 1578), otherwise already Ps/s."""
        if self.unit_system == MECHANICAL_UNITS:
            return value * 1000 * self.pulses_per_rev / (6 * self.travel_per_rev)
        return value

    @property
    def max_speed(self) -> float:
        return self.speed_hz(self.values[4])

    @property
    def start_speed(self) -> float:
        return self.speed_hz(self.values[5])

    @property
    def creep_speed(self) -> float:
        return self.speed_hz(self.values[6])

    @property
    def acceleration(self) -> float:
        """Pulses/s^2: parameter 4 reached in parameter-8 time (FB 1597-1602); infinite for 0."""
        return _slope(self.max_speed, self.values[8])

    @property
    def deceleration(self) -> float:
        """Parameter 12, or parameter 8 when 12 is 0 (FB 1638-1642)."""
        return _slope(self.max_speed, self.values[12] or self.values[8])

    def interpolation_slope(self, speed: float) -> float:
        """FUN147: the line speed reached in parameter-13 time (FB 1644-1647)."""
        return _slope(speed, self.values[13])

    @property
    def home_up(self) -> bool:
        """Parameter 9-1: 0 = home in the counting-up direction (FB 1620-1628)."""
        return (self.values[9] >> 8) & 0xFF == 0

    def io_field(self, which: int) -> int:
        """Parameter 15 byte 15-0 (DOG), 15-1 (limit), 15-2 (PG0) or 15-3 (CLR)."""
        return (self.values[15] >> (8 * which)) & 0xFF


def _slope(speed: float, time_ms: int) -> float:
    if time_ms <= 0:
        return float("inf")
    return speed / (time_ms / 1000)
