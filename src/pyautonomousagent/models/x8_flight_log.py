"""Checks of the X8's take-off and landing cycles, iteration by iteration.

:class:`FlightLog` watches an X8 model (either implementation) after each iteration: the
cycles each aircraft completes (touchdown, stop, take-off, back at cruise altitude), the
sink rate and airspeed at every touchdown, the lowest altitude, and the lowest airspeed while
airborne; :func:`stall_speed` is the model's own 1 g stall speed, the floor that airspeed is
held against. ``scripts/x8_cycles.py`` and ``tests/test_x8_landing.py`` use both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pyautonomousagent.models import x8_dynamics as dyn
from pyautonomousagent.models import x8_modes as modes
from pyautonomousagent.models.x8 import X8Model
from pyautonomousagent.models.x8_params import X8Parameters, load_parameters

#: Touchdown limits (docs/x8.md, "Take-off and landing"): sink rate (m/s) and airspeed as a
#: multiple of the stall speed.
MAX_TOUCHDOWN_SINK = 1.0
MAX_TOUCHDOWN_SPEED_RATIO = 2.0


def lift_coefficient_max(params: X8Parameters | None = None) -> float:
    """The largest lift coefficient of the model's lift curve (stall blending, elevator and
    pitch rate 0), over angles of attack 0..0.8 rad in steps of 1e-4 rad."""
    p = params or load_parameters()
    a = p.aero
    alpha = np.arange(0.0, 0.8, 1e-4)
    sigma = dyn._stall_blend(alpha, a.M, a.a_0)
    flat = 2.0 * np.sin(alpha) ** 2 * np.cos(alpha)
    return float(((1 - sigma) * (a.C_L_0 + a.C_L_alpha * alpha) + sigma * flat).max())


def stall_speed(params: X8Parameters | None = None) -> float:
    """The 1 g stall speed (m/s): ``sqrt(2 m g / (rho S C_L,max))``."""
    p = params or load_parameters()
    weight = p.airframe.mass * p.g
    return math.sqrt(2.0 * weight / (p.rho * p.airframe.S_wing * lift_coefficient_max(p)))


@dataclass
class FlightLog:
    """What the X8s did, gathered by :meth:`watch` after each iteration.

    Attributes:
        cycles: completed cycles per aircraft (touchdown, stop, take-off, back in FLIGHT).
        sinks, speeds: sink rate (m/s) and airspeed (m/s) at every touchdown.
        strikes: touchdowns without a flare (from FLIGHT or APPROACH), all aircraft.
        min_altitude: the lowest altitude of any aircraft (m).
        min_airspeed: the lowest airspeed of an airborne aircraft (m/s), take-off roll and
            roll-out excluded.
        iterations: iterations watched.
    """

    n: int
    cycles: np.ndarray = field(init=False)
    sinks: list[float] = field(default_factory=list)
    speeds: list[float] = field(default_factory=list)
    strikes: int = 0
    min_altitude: float = math.inf
    min_airspeed: float = math.inf
    iterations: int = 0

    def __post_init__(self) -> None:
        self.cycles = np.zeros(self.n, dtype=np.int64)
        self._touchdowns = np.zeros(self.n, dtype=np.int64)
        self._landed = np.zeros(self.n, dtype=bool)
        self._phase = np.full(self.n, modes.FLIGHT, dtype=np.int64)

    def watch(self, model: X8Model) -> None:
        """Take in the model's state after one iteration."""
        f, phase = model.flight, model.phase
        new = np.flatnonzero(model.touchdowns != self._touchdowns)
        for a in new:
            self.sinks.append(float(model.touchdown_sink[a]))
            self.speeds.append(float(model.touchdown_speed[a]))
            self._landed[a] = True
        self._touchdowns = model.touchdowns.copy()
        self.strikes = int(model.strikes.sum())
        back = self._landed & (phase == modes.FLIGHT) & (self._phase == modes.CLIMB_OUT)
        self.cycles[back] += 1
        self._landed[back] = False
        self._phase = phase.copy()
        self.min_altitude = min(self.min_altitude, float(f.altitude.min()))
        airborne = (f.altitude > 0.0) & (phase != modes.PARKED)
        if airborne.any():
            self.min_airspeed = min(self.min_airspeed, float(f.airspeed[airborne].min()))
        self.iterations += 1

    def summary(self, stall: float) -> str:
        """The figures, one per line."""
        sinks, speeds = np.array(self.sinks), np.array(self.speeds)
        lines = [
            f"iterations: {self.iterations}, aircraft: {self.n}",
            f"cycles (land, refuel, take off) per aircraft: {self.cycles.tolist()}",
            f"touchdowns: {len(sinks)}, ground strikes (no flare): {self.strikes}",
        ]
        if len(sinks):
            lines += [
                f"sink rate at touchdown: max {sinks.max():.3f} m/s, mean {sinks.mean():.3f} m/s"
                f" (limit {MAX_TOUCHDOWN_SINK:.1f})",
                f"airspeed at touchdown: {speeds.min():.2f}..{speeds.max():.2f} m/s (limit "
                f"{MAX_TOUCHDOWN_SPEED_RATIO * stall:.2f} = {MAX_TOUCHDOWN_SPEED_RATIO:g} x stall)",
            ]
        lines += [
            f"lowest altitude: {self.min_altitude + 0.0:.6f} m",
            f"lowest airspeed airborne: {self.min_airspeed:.2f} m/s (stall speed {stall:.2f})",
        ]
        return "\n".join(lines)

    def problems(self, stall: float) -> list[str]:
        """What breaks the limits (empty: none)."""
        out = []
        if self.strikes:
            out.append(f"{self.strikes} ground strikes")
        if self.sinks and max(self.sinks) > MAX_TOUCHDOWN_SINK:
            out.append(f"touchdown sink rate {max(self.sinks):.3f} m/s")
        if self.speeds and max(self.speeds) > MAX_TOUCHDOWN_SPEED_RATIO * stall:
            out.append(f"touchdown airspeed {max(self.speeds):.2f} m/s")
        if self.min_altitude < 0.0:
            out.append(f"altitude {self.min_altitude} m below the ground")
        if self.min_airspeed <= stall:
            out.append(f"airspeed {self.min_airspeed:.2f} m/s at or below stall")
        return out
