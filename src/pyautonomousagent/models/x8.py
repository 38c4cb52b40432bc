"""The Skywalker X8 as the swarm's motion model: settings, what the loop sees, and the
vectorised implementation for the batched engine.

Frames: the world's x is east and y is north (metres), as in the 2-D model; the aircraft's
state is in NED (north, east, down) with the origin at the world's (0, 0), so
``x = east``, ``y = north`` and ``altitude = -down``. The swarm's ``heading`` column is the
course over ground, degrees clockwise from north in [0, 360), and ``speed`` is the airspeed
in m/s (in still air, the speed the autopilot holds). The model records ``altitude`` (m),
``airspeed`` (m/s), ``roll`` and ``pitch`` (degrees) beside the swarm's columns.

Each iteration the loop calls :meth:`X8Model.advance` (Phase 2: integrate one time step with
the commands of the last Phase 4) and :meth:`X8Model.control` (Phase 4: the autopilot turns
the tree's requested heading and speed into surface and throttle commands). An agent with no
energy is treated as grounded: its state is held and its speed column reads 0.

Take-off and landing (:mod:`~pyautonomousagent.models.x8_modes`): where the mission declares
the columns, the tree requests a mode (cruise, land, take off) and the glide path's altitude;
the model runs a phase machine per aircraft, puts it on the ground after each step where it
reaches it, and holds it where it stopped while parked.
"""

from __future__ import annotations

import logging
import math
from dataclasses import astuple, dataclass, fields

import numpy as np

from pyautonomousagent import jit
from pyautonomousagent.arrays import arctan2
from pyautonomousagent.models import x8_dynamics as dyn
from pyautonomousagent.models import x8_kernel as kernel
from pyautonomousagent.models import x8_modes as modes
from pyautonomousagent.models.autopilot import (
    AttitudeController,
    Guidance,
    GuidanceGains,
    attitude_gains,
)
from pyautonomousagent.models.x8_params import X8Parameters, load_parameters

log = logging.getLogger("pyautonomousagent")

#: Turbulence intensities of the Dryden model (MIL-F-8785C) that PyFly offers.
TURBULENCE_INTENSITIES = ("light", "moderate", "severe")


@dataclass(frozen=True)
class X8Settings:
    """The X8's scenario settings (the ``x8:`` mapping of a scenario file).

    Attributes:
        altitude: altitude the autopilot holds (m).
        initial_altitude: altitude at the start (m).
        initial_airspeed: airspeed at the start, wings level along the initial heading (m/s).
        min_airspeed: floor of the airspeed reference (m/s); the refuelling leaf requests 0.
        dt: time step (s) = one iteration.
        turbulence: Dryden turbulence on (PyFly reference model only).
        turbulence_intensity: "light", "moderate" or "severe".
        course_kp, course_ki, course_kd, max_roll: course PID (rad -> rad; limit in degrees).
        altitude_kp, altitude_ki, altitude_kd, max_pitch: altitude PID (m -> rad; degrees).
            ``altitude_kp`` is 0.1 rad/m, not the notebook's 1.0 (docs/x8.md).
        flare_height (m), flare_time (s), touchdown_sink (m/s), flare_pitch (deg),
            flare_gain (deg per m/s), max_flare_pitch (deg): the flare
            (:func:`x8_modes.overrides`).
        rotation_speed (m/s), rotation_pitch (deg), climb_out_margin (m): the take-off.
        friction_rolling, friction_braking: Coulomb friction on the take-off roll and on the
            roll-out; max_ground_pitch (deg): the largest pitch on the ground.
    """

    altitude: float = 20.0
    initial_altitude: float = 20.0
    initial_airspeed: float = 22.0
    min_airspeed: float = 18.0
    dt: float = 0.01
    turbulence: bool = False
    turbulence_intensity: str = "light"
    course_kp: float = 1.0
    course_ki: float = 1e-5
    course_kd: float = 0.01
    max_roll: float = 45.0
    altitude_kp: float = 0.1  # the notebook's 1.0 limit-cycles (docs/x8.md)
    altitude_ki: float = 1e-4
    altitude_kd: float = 0.01
    max_pitch: float = 30.0
    flare_height: float = 3.0
    flare_time: float = 1.0
    touchdown_sink: float = 0.3
    flare_pitch: float = 2.0
    flare_gain: float = 6.0
    max_flare_pitch: float = 12.0
    rotation_speed: float = 14.0
    rotation_pitch: float = 10.0
    climb_out_margin: float = 2.0
    friction_rolling: float = 0.04
    friction_braking: float = 0.4
    max_ground_pitch: float = 12.0

    def mode_settings(self) -> modes.ModeSettings:
        """The take-off and landing phases' settings (the fields of the same names), angles
        in radians."""
        values = {f.name: getattr(self, f.name) for f in fields(modes.ModeSettings)}
        angles = {"flare_pitch", "flare_gain", "max_flare_pitch", "rotation_pitch",
                  "max_ground_pitch"}  # fmt: skip
        return modes.ModeSettings(
            **{name: math.radians(v) if name in angles else v for name, v in values.items()}
        )

    def gains(self) -> GuidanceGains:
        """The guidance PIDs' gains and limits (the fields of the same names)."""
        return GuidanceGains(**{f.name: getattr(self, f.name) for f in fields(GuidanceGains)})


@dataclass
class Flight:
    """What the loop and the autopilot read of N aircraft; every array has shape (N,).

    Attributes:
        north, east, altitude: position (m).
        airspeed: m/s.
        course: course over ground, rad clockwise from north, in (-pi, pi].
        roll, pitch: Euler angles (rad).
        p, q: roll and pitch rates (rad/s).
        climb: vertical speed, up (m/s).
    """

    north: np.ndarray
    east: np.ndarray
    altitude: np.ndarray
    airspeed: np.ndarray
    course: np.ndarray
    roll: np.ndarray
    pitch: np.ndarray
    p: np.ndarray
    q: np.ndarray
    climb: np.ndarray


def initial_state(
    settings: X8Settings, x: np.ndarray, y: np.ndarray, heading: np.ndarray
) -> np.ndarray:
    """The start: at (x, y) and ``initial_altitude``, wings level, flying along ``heading``.

    Args:
        settings: the X8 settings.
        x, y: east and north positions (m), shape (N,).
        heading: degrees clockwise from north, shape (N,).

    Returns:
        The state array of :mod:`x8_dynamics`, shape (STATES, N); rates, sideslip, angle of
        attack, surfaces and throttle are zero.
    """
    n = len(x)
    state = np.zeros((dyn.STATES, n))
    zeros = np.zeros(n)
    state[dyn.QUATERNION] = dyn.quaternion_from_euler(zeros, zeros, np.radians(heading))
    state[dyn.PN], state[dyn.PE], state[dyn.PD] = y, x, -settings.initial_altitude
    state[dyn.U] = settings.initial_airspeed
    return state


def observe(state: np.ndarray) -> Flight:
    """The :class:`Flight` view of a state array of shape (STATES, N) (rows are views)."""
    (e0, e1, e2, e3), (u, v, w) = state[dyn.QUATERNION], state[dyn.VELOCITY]
    north, east, down = dyn.body_to_ned(state[dyn.QUATERNION], u, v, w)  # ground velocity, m/s
    s = np.minimum(np.maximum(2 * (e0 * e2 - e1 * e3), -1.0), 1.0)  # sin(pitch)
    y = np.array([east, 2 * (e0 * e1 + e2 * e3), s])
    x = np.array([north, e0 * e0 + e3 * e3 - e1 * e1 - e2 * e2, np.sqrt((1.0 - s) * (1.0 + s))])
    course, roll, pitch = arctan2(y, x)  # one call: dyn.roll_pitch's angles and the course
    airspeed = np.sqrt(u * u + v * v + w * w)
    altitude = 0.0 - state[dyn.PD]  # +0.0 on the ground, not -0.0
    return Flight(state[dyn.PN], state[dyn.PE], altitude, airspeed, course, roll, pitch,
                  state[dyn.P], state[dyn.Q], -down)  # fmt: skip


class X8Model:
    """What both X8 implementations share: the guidance and the swarm's columns.

    Subclasses set ``self.flight`` and implement :meth:`advance` and :meth:`_attitude`.

    Args:
        settings: the X8 settings.
        n: number of agents N.
    """

    name = "x8"

    def __init__(self, settings: X8Settings, n: int) -> None:
        self.settings = settings
        self.guidance = Guidance(
            settings.gains(), settings.altitude, settings.min_airspeed, settings.dt, n
        )
        self.flight: Flight
        self.modes = settings.mode_settings()
        #: Each aircraft's phase (:mod:`x8_modes`), (N,) int64.
        self.phase = np.full(n, modes.FLIGHT, dtype=np.int64)
        #: Touchdowns from the air (from FLARE, APPROACH or FLIGHT) and ground strikes (from
        #: APPROACH or FLIGHT: the ground met without a flare) per aircraft, (N,) int64.
        self.touchdowns = np.zeros(n, dtype=np.int64)
        self.strikes = np.zeros(n, dtype=np.int64)
        #: Sink rate (m/s) and speed (m/s) at each aircraft's latest touchdown, (N,).
        self.touchdown_sink = np.zeros(n)
        self.touchdown_speed = np.zeros(n)
        self._overrides = modes.overrides(
            self.phase, None, np.zeros(n), np.zeros(n), self.modes
        )  # all FLIGHT: no override
        self._quiet = True  # every aircraft in FLIGHT: no override, none parked

    def columns(self) -> dict[str, np.ndarray]:
        """Recorded beside the swarm: altitude (m), airspeed (m/s), roll and pitch (deg)."""
        f = self.flight
        return {
            "altitude": f.altitude,
            "airspeed": f.airspeed,
            "roll": np.degrees(f.roll),
            "pitch": np.degrees(f.pitch),
        }

    def write(self, s: dict[str, np.ndarray], moving: np.ndarray | None = None) -> None:
        """Fill the swarm's x, y, speed and heading columns from ``self.flight`` (and the
        phase column, where the mission declares it). At rest (airspeed 0, on the ground)
        there is no course: the heading column keeps the last one."""
        f = self.flight
        s["x"][:] = f.east
        s["y"][:] = f.north
        s["speed"][:] = f.airspeed if moving is None else np.where(moving, f.airspeed, 0.0)
        heading = np.mod(np.degrees(f.course), 360.0)
        s["heading"][:] = np.where(f.airspeed == 0.0, s["heading"], heading)
        if modes.PHASE_COLUMN in s:
            s[modes.PHASE_COLUMN][:] = self.phase

    def moving(self, moving: np.ndarray) -> np.ndarray:
        """The aircraft that fly this step: ``moving`` and not parked."""
        if self._quiet:
            return moving
        return np.asarray(moving, dtype=bool) & (self.phase != modes.PARKED)

    def land(self, state: np.ndarray, moving: np.ndarray) -> np.ndarray:
        """The ground (:func:`x8_modes.ground_contact`) for the moving aircraft of ``state``
        (STATES, N) at or below it, in place; their phases and touchdown records updated.

        Returns:
            The rows put on the ground, (K,) int.
        """
        rows = np.flatnonzero(moving & (state[dyn.PD] >= 0.0))
        if rows.size == 0:
            return rows
        b = state[:, rows]
        mu = modes.friction(self.phase[rows], self.modes)
        contact = modes.ground_contact(b, mu, self.modes.max_ground_pitch)
        state[:, rows] = b
        was = self.phase[rows]
        landed = modes.after_contact(self.phase, rows, contact)
        struck = landed & (was != modes.FLARE)
        self.touchdowns[rows[landed]] += 1
        self.strikes[rows[struck]] += 1
        self.touchdown_sink[rows[landed]] = contact.sink[landed]
        self.touchdown_speed[rows[landed]] = contact.speed[landed]
        self._quiet = not self.phase.any()  # FLIGHT is 0
        return rows

    def references(self, s: dict[str, np.ndarray]) -> modes.Overrides:
        """Phase 4's changes of phase and what the phases impose (:mod:`x8_modes`)."""
        mode = s.get(modes.MODE_COLUMN)
        if self._quiet and (mode is None or not mode.any()):
            return self._overrides
        f = self.flight
        modes.transitions(self.phase, mode, f.altitude, f.airspeed, self.modes)
        self._quiet = not self.phase.any()  # FLIGHT is 0
        if self._quiet:
            return self._overrides
        return modes.overrides(
            self.phase, s.get(modes.ALTITUDE_COLUMN), f.altitude, f.climb, self.modes
        )

    def settle(self, o: modes.Overrides) -> None:
        """After the commands: clear the integrators (and the previous errors) of the PIDs
        whose output a phase overrides, so that none winds up on the ground."""
        if self._quiet:
            return
        roll, pitch, throttle = ~np.isnan(o.roll), ~np.isnan(o.pitch), ~np.isnan(o.throttle)
        for pid, held in ((self.guidance.course, roll), (self.guidance.height, pitch)):
            pid.integral[held] = 0.0
            pid.previous[held] = np.nan
        self._clear_attitude(throttle, roll, self.phase == modes.PARKED)

    def _clear_attitude(self, airspeed: np.ndarray, roll: np.ndarray, pitch: np.ndarray) -> None:
        """Zero the attitude PID's airspeed, roll and pitch integrators where given."""
        raise NotImplementedError

    def control(self, s: dict[str, np.ndarray]) -> None:
        """Phase 4: the autopilot's commands for the requested heading and speed, and the
        phase's overrides."""
        f = self.flight
        o = self.references(s)
        roll, pitch, airspeed = self.guidance.references(
            f.course, f.altitude, s["requested_heading"], s["requested_speed"], o.altitude
        )
        roll = np.where(np.isnan(o.roll), roll, o.roll)
        pitch = np.where(np.isnan(o.pitch), pitch, o.pitch)
        self._attitude((roll, pitch, airspeed), o.throttle)
        self.settle(o)

    def advance(self, s: dict[str, np.ndarray], moving: np.ndarray) -> None:
        """Phase 2: fly one time step (the agents where ``moving``) and update ``s``."""
        raise NotImplementedError

    def _attitude(
        self, refs: tuple[np.ndarray, np.ndarray, np.ndarray], throttle: np.ndarray
    ) -> None:
        """The commands for the references; ``throttle`` overrides the airspeed PID's where
        not NaN."""
        raise NotImplementedError


#: Without numba, the plain-Python kernel flies up to this many agents (about 0.16 ms per
#: agent and iteration against 0.5-0.7 ms per iteration for the NumPy code).
PYTHON_KERNEL_AGENTS = 3


class X8Vectorised(X8Model):
    """All N X8s integrated at once (fixed step, :func:`x8_dynamics.step`), autopilot on arrays.

    Agent by agent (:mod:`~pyautonomousagent.models.x8_kernel`), each iteration is two calls
    that give the same bits as the NumPy code, which stays the reference: compiled where numba
    is installed (the ``[fast]`` extra, :func:`pyautonomousagent.jit.available`), else plain
    Python, which is faster than NumPy's fixed cost per call for up to
    :data:`PYTHON_KERNEL_AGENTS` agents.

    Args:
        settings: the X8 settings.
        s: the swarm's columns; x, y and heading give the start, and all four are updated.
        params: the aircraft's parameters (by default read from the installed package).
        agent_by_agent: use the kernel; by default where it is compiled, or for a few agents.
    """

    def __init__(
        self,
        settings: X8Settings,
        s: dict[str, np.ndarray],
        params: X8Parameters | None = None,
        agent_by_agent: bool | None = None,
    ) -> None:
        n = len(s["x"])
        super().__init__(settings, n)
        self.constants = dyn.Constants.of(params or load_parameters(), settings.dt)
        self.state = initial_state(settings, s["x"], s["y"], s["heading"])
        self.commands = np.zeros((dyn.COMMANDS, n))
        self.attitude = AttitudeController(attitude_gains(settings.dt), settings.dt, n)
        if agent_by_agent is None:
            agent_by_agent = jit.available() or n <= PYTHON_KERNEL_AGENTS
        if agent_by_agent:
            agent_by_agent = self._compile(n)
        self.agent_by_agent = agent_by_agent
        #: True where the kernel runs compiled (numba).
        self.compiled = agent_by_agent and jit.available()
        self.flight = observe(self.state)
        self.write(s)

    def _compile(self, n: int) -> bool:
        """Pack the kernel's constants, compile (or load) the kernel and check it against the
        NumPy code (:meth:`_kernel_agrees`); if it agrees, put the controllers' state in one
        (7, N) array (the controllers keep views of its rows), and the touchdown records in
        two (2, N) arrays. Returns whether it agreed."""
        self._packed = kernel.pack_constants(self.constants)
        self._gains = kernel.pack_gains(self.guidance, self.attitude, self.constants)
        self._phases = kernel.pack_modes(self.modes)
        self._none = np.zeros(0)  # a column the mission does not declare
        empty, phase = np.zeros(0), np.zeros(0, dtype=np.int64)
        kernel.control(
            np.zeros((kernel.FLIGHT_ROWS, 0)), (empty, empty, empty, empty), phase,
            (self._gains, self._phases), np.zeros((7, 0)), np.zeros((3, 0)),
        )  # fmt: skip
        if not self._kernel_agrees():
            log.warning(
                "the X8 kernel does not give the NumPy code's bits here (a stale numba cache "
                "after a change to arrays.py, x8_dynamics.py or x8_modes.py?); using the "
                "NumPy code"
            )
            return False
        pids = np.zeros((7, n))
        pids[1], pids[3] = np.nan, np.nan
        course, height = self.guidance.course, self.guidance.height
        course.integral, course.previous, height.integral, height.previous = pids[:4]
        self.attitude.integral = pids[4:]
        self._pids = pids
        counts, marks = np.zeros((2, n), dtype=np.int64), np.zeros((2, n))
        self.touchdowns, self.strikes = counts
        self.touchdown_sink, self.touchdown_speed = marks
        self._ground = (self.phase, counts, marks, self._phases)
        self._flight = np.empty((kernel.FLIGHT_ROWS, n))
        return True

    def _kernel_agrees(self) -> bool:
        """One step of up to 8 of the UAVs, disturbed (rates, sideslip, climb, surfaces in
        motion; the first one below the ground), by the kernel and by the NumPy code: the
        same bits? Compiled code keeps the constants it imported when it was cached, so this
        guards against a stale cache."""
        y = self.state[:, :8].copy()
        k = y.shape[1]
        wiggle = np.linspace(-1.0, 1.0, k)
        y[dyn.RATES] += 0.3 * wiggle
        y[dyn.V] += 2.0 * wiggle
        y[dyn.W] -= 1.5 * wiggle
        y[dyn.ELEVON_RATES] = 4.0 * wiggle
        y[dyn.PD, :1] = 0.5
        commands = np.array([0.2 * wiggle, -0.3 * wiggle, 0.5 + 0.4 * wiggle])
        want = dyn.step(y, commands, self.constants)
        reference = X8Model(self.settings, k)  # all in FLIGHT: the NumPy code's ground
        reference.land(want, np.ones(k, dtype=bool))
        got, flight = np.empty_like(y), np.empty((kernel.FLIGHT_ROWS, k))
        phases = np.zeros(k, dtype=np.int64)
        ground = (phases, np.zeros((2, k), dtype=np.int64), np.zeros((2, k)), self._phases)
        columns = (np.zeros(k), np.zeros(k), np.zeros(k), np.zeros(k), self._none)
        c = self.constants
        kernel.advance(y, commands, np.ones(k, dtype=bool), (self._packed, c.aero, c.inertia),
                       (got, flight), ground, columns)  # fmt: skip
        same = np.array_equal(got, want) and np.array_equal(phases, reference.phase)
        return same and np.array_equal(flight, astuple(observe(want)))

    def advance(self, s: dict[str, np.ndarray], moving: np.ndarray) -> None:
        """Phase 2: one time step of ``settings.dt`` for the agents where ``moving`` (and not
        parked), then the ground; agent by agent, one compiled call."""
        if not self.agent_by_agent:
            moving = np.asarray(self.moving(moving), dtype=bool)
            new = dyn.step(self.state, self.commands, self.constants)
            self.state = new if moving.all() else np.where(moving, new, self.state)
            self.land(self.state, moving)
            self.flight = observe(self.state)
            self.write(s, moving)
            return
        new, self._flight = np.empty_like(self.state), np.empty_like(self._flight)
        c = self.constants
        columns = (s["x"], s["y"], s["speed"], s["heading"], s.get(modes.PHASE_COLUMN, self._none))
        kernel.advance(self.state, self.commands, np.asarray(moving, dtype=bool),
                       (self._packed, c.aero, c.inertia), (new, self._flight), self._ground,
                       columns)  # fmt: skip
        self.state = new
        self.flight = Flight(*self._flight)

    def control(self, s: dict[str, np.ndarray]) -> None:
        """Phase 4: the autopilot's commands for the requested heading and speed (and the
        phases' changes and overrides); agent by agent, one compiled call."""
        if not self.agent_by_agent:
            super().control(s)
            return
        mode = s.get(modes.MODE_COLUMN, self._none)
        glide = s.get(modes.ALTITUDE_COLUMN, self._none)
        requests = (s["requested_heading"], s["requested_speed"], mode, glide)
        kernel.control(self._flight, requests, self.phase, (self._gains, self._phases),
                       self._pids, self.commands)  # fmt: skip

    def _clear_attitude(self, airspeed: np.ndarray, roll: np.ndarray, pitch: np.ndarray) -> None:
        for row, held in enumerate((airspeed, roll, pitch)):
            self.attitude.integral[row][held] = 0.0

    def _attitude(
        self, refs: tuple[np.ndarray, np.ndarray, np.ndarray], throttle: np.ndarray
    ) -> None:
        f = self.flight
        elevator, aileron, pid_throttle = self.attitude.commands(
            refs, f.roll, f.pitch, f.airspeed, f.p, f.q
        )
        self.commands[: dyn.CMD_ELEVON_L + 1] = dyn.elevon_commands(
            elevator, aileron, self.constants
        )
        self.commands[dyn.CMD_THROTTLE] = np.where(np.isnan(throttle), pid_throttle, throttle)
