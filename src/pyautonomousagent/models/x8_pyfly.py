"""The reference X8: one ``pyfly.PyFly`` simulator and one PyFly ``PIDController`` per agent.

This is the paper's set-up (its second set of tests): every UAV is its own PyFly instance,
stepped one after the other, built from the configuration and parameter files of the installed
package (never the working directory). PyFly integrates each step with SciPy's adaptive
``solve_ivp`` (RK45, rtol 1e-3, atol 1e-6), which is why it costs milliseconds per UAV and
iteration; the vectorised model (:class:`~pyautonomousagent.models.x8.X8Vectorised`) is held
against it by the test suite.

Two things differ from calling PyFly naively, both documented in docs/x8.md:

- PyFly keeps the history of every variable of every step (and of the attitude at every
  evaluation of its right-hand side); the adapter drops all but the latest value every
  :data:`HISTORY_KEPT` steps, so long runs (200,000 iterations) keep bounded memory.
- PyFly 0.1.2 passes its gust model's arguments in the wrong order (the 300-step simulation
  length lands in the sample time ``dt``); with turbulence on, the adapter replaces the gust
  model with PyFly's own ``DrydenGustModel`` built with the right time step, wingspan,
  altitude and airspeed, then seeds it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pyautonomousagent.models import x8_dynamics as dyn
from pyautonomousagent.models.x8 import TURBULENCE_INTENSITIES, Flight, X8Model, X8Settings
from pyautonomousagent.models.x8_dynamics import body_to_ned
from pyautonomousagent.models.x8_params import CONFIG_FILE, PARAMETER_FILE, pyfly_file

#: Steps between two trimmings of PyFly's per-variable histories (PyFly appends every variable
#: at every step, and the attitude at every evaluation of its right-hand side, ~20 per step).
HISTORY_KEPT = 100


class FlightEnvelopeError(RuntimeError):
    """PyFly stopped a step because a state left its constraints (e.g. a body rate)."""


def agent_seeds(seed: int, n: int) -> list[int]:
    """Independent 31-bit seeds for N agents, derived from the run's seed."""
    children = np.random.SeedSequence(seed).spawn(n)
    return [int(c.generate_state(1)[0] & 0x7FFFFFFF) for c in children]


def _make_pyfly(settings: X8Settings, seed: int) -> Any:
    """One seeded PyFly simulator from the installed package's files."""
    from pyfly.pyfly import DrydenGustModel, PyFly

    if settings.turbulence_intensity not in TURBULENCE_INTENSITIES:
        raise ValueError(f"turbulence_intensity must be one of {TURBULENCE_INTENSITIES}")
    config = {
        "dt": settings.dt,
        "turbulence": settings.turbulence,
        "turbulence_intensity": settings.turbulence_intensity,
    }
    aircraft = PyFly(str(pyfly_file(CONFIG_FILE)), str(pyfly_file(PARAMETER_FILE)), config)
    if settings.turbulence:
        aircraft.wind.dryden = DrydenGustModel(
            dt=settings.dt,
            b=float(aircraft.params["b"]),
            h=settings.altitude,
            V_a=settings.initial_airspeed,
            intensity=settings.turbulence_intensity,
        )
    aircraft.seed(seed)
    return aircraft


def _start(settings: X8Settings, x: float, y: float, heading: float) -> dict[str, Any]:
    """PyFly's reset state for the start of :func:`~pyautonomousagent.models.x8.initial_state`."""
    start: dict[str, Any] = {"yaw": float(np.radians(heading)), "wind": (0.0, 0.0, 0.0)}
    start.update(dict.fromkeys(["roll", "pitch", "omega_p", "omega_q", "omega_r"], 0.0))
    start.update(position_n=float(y), position_e=float(x), position_d=-settings.initial_altitude)
    start.update(velocity_u=settings.initial_airspeed, velocity_v=0.0, velocity_w=0.0)
    start.update(dict.fromkeys(["elevon_left", "elevon_right", "throttle"], (0.0, 0.0)))
    return start


#: PyFly's names of the airframe's 13 states, in the rows of :mod:`x8_dynamics` (after the
#: quaternion).
_AIRFRAME = ["omega_p", "omega_q", "omega_r", "position_n", "position_e", "position_d"]
_AIRFRAME += ["velocity_u", "velocity_v", "velocity_w"]


def airframe(aircraft: Any) -> np.ndarray:
    """A PyFly simulator's airframe state as the rows E0..W of :mod:`x8_dynamics`, (13,)."""
    values = list(aircraft.state["attitude"].value) + aircraft.get_states_vector(_AIRFRAME)
    return np.array(values, dtype=float)


def set_airframe(aircraft: Any, b: np.ndarray) -> None:
    """Replace the latest airframe state of a PyFly simulator with ``b`` (13,), and the
    Euler angles and air data PyFly derives from it."""
    attitude = aircraft.state["attitude"]
    attitude.quaternion = np.array(b[dyn.QUATERNION])
    attitude.history[-1] = attitude.quaternion
    angles = attitude.as_euler_angle()
    values = dict(zip(_AIRFRAME, b[4:13].tolist(), strict=True))
    values.update(roll=angles["roll"], pitch=angles["pitch"], yaw=angles["yaw"])
    theta = [angles["roll"], angles["pitch"], angles["yaw"]]
    velocity = np.array(b[dyn.VELOCITY])
    at_rest = not velocity.any()  # PyFly's sideslip asin(v / Va) is 0 / 0 there
    air = (0.0, 0.0, 0.0) if at_rest else aircraft._calculate_airspeed_factors(theta, velocity)
    values.update(zip(["Va", "alpha", "beta"], air, strict=True))
    for name, value in values.items():
        var = aircraft.state[name]
        var.value = value
        if var.history:
            var.history[-1] = value


def _trim_history(aircraft: Any) -> None:
    """Keep only the latest entry of every history PyFly holds (in place)."""
    for var in aircraft.state.values():
        history = var.history
        if isinstance(history, dict):
            for values in history.values():
                del values[:-1]
        elif history:
            del history[:-1]


class X8PyFly(X8Model):
    """N X8s, each its own PyFly simulator and PID controller, stepped one by one.

    Args:
        settings: the X8 settings (turbulence is honoured here).
        s: the swarm's columns; x, y and heading give the start, and all four are updated.
        seed: the run's seed; agent i's simulator gets its own seed derived from it.
    """

    def __init__(self, settings: X8Settings, s: dict[str, np.ndarray], seed: int = 0) -> None:
        from pyfly.pid_controller import PIDController

        n = len(s["x"])
        super().__init__(settings, n)
        self.aircraft = [_make_pyfly(settings, k) for k in agent_seeds(seed, n)]
        for i, aircraft in enumerate(self.aircraft):
            aircraft.reset(state=_start(settings, s["x"][i], s["y"][i], s["heading"][i]))
        self.pids = [PIDController(settings.dt) for _ in range(n)]
        self.commands = np.zeros((n, 3))  # elevator, aileron (rad), throttle per agent
        self.steps = 0
        #: PyFly's airspeed floor (m/s), the configuration's ``Va`` ``value_min``.
        self.airspeed_floor = float(self.aircraft[0].state["Va"].value_min) if n else 1e-6
        self.flight = self._observe()
        self.write(s)

    def advance(self, s: dict[str, np.ndarray], moving: np.ndarray) -> None:
        """Phase 2: one PyFly step per agent where ``moving``.

        Raises:
            FlightEnvelopeError: PyFly refused a step (a state left its constraints).
        """
        moving = self.moving(moving)
        for i in np.flatnonzero(moving):
            if self.aircraft[i].state["Va"].value == 0.0:  # at rest, as the ground leaves it
                self._nudge(int(i))
            ok, info = self.aircraft[i].step(self.commands[i].copy())
            if not ok:
                raise FlightEnvelopeError(f"agent {i}: PyFly stopped the step: {info}")
        self._ground(np.asarray(moving, dtype=bool))
        self.steps += 1
        if self.steps % HISTORY_KEPT == 0:
            for aircraft in self.aircraft:
                _trim_history(aircraft)
        self.flight = self._observe()
        self.write(s, moving)

    def _nudge(self, i: int) -> None:
        """Start aircraft i from PyFly's airspeed floor (1e-6 m/s forward) rather than rest,
        where PyFly's sideslip would be 0 / 0."""
        b = airframe(self.aircraft[i])
        b[dyn.U] = self.airspeed_floor
        set_airframe(self.aircraft[i], b)

    def _ground(self, moving: np.ndarray) -> None:
        """The ground (:meth:`X8Model.land`) applied to PyFly's states."""
        down = np.array([a.state["position_d"].value for a in self.aircraft], dtype=float)
        if not (moving & (down >= 0.0)).any():
            return
        state = np.zeros((dyn.STATES, len(self.aircraft)))
        state[dyn.BODY] = np.array([airframe(a) for a in self.aircraft]).T
        for i in self.land(state, moving):
            set_airframe(self.aircraft[i], state[dyn.BODY, i])

    def _observe(self) -> Flight:
        names = ["position_n", "position_e", "position_d", "Va", "roll", "pitch", "omega_p"]
        names += ["omega_q", "velocity_u", "velocity_v", "velocity_w"]
        values = np.array([a.get_states_vector(names) for a in self.aircraft], dtype=float).T
        north, east, down, airspeed, roll, pitch, p, q, u, v, w = values
        quaternion = np.array([a.state["attitude"].value for a in self.aircraft], dtype=float).T
        velocity = body_to_ned(quaternion, u, v, w)
        course, climb = np.arctan2(velocity[1], velocity[0]), -velocity[2]
        return Flight(north, east, 0.0 - down, airspeed, course, roll, pitch, p, q, climb)

    def _attitude(
        self, refs: tuple[np.ndarray, np.ndarray, np.ndarray], throttle: np.ndarray
    ) -> None:
        f = self.flight
        roll_ref, pitch_ref, airspeed_ref = refs
        for i, pid in enumerate(self.pids):
            pid.set_reference(phi=roll_ref[i], theta=pitch_ref[i], va=airspeed_ref[i])
            self.commands[i] = pid.get_action(
                f.roll[i], f.pitch[i], f.airspeed[i], [f.p[i], f.q[i]]
            )
            if not np.isnan(throttle[i]):
                self.commands[i, 2] = throttle[i]

    def _clear_attitude(self, airspeed: np.ndarray, roll: np.ndarray, pitch: np.ndarray) -> None:
        for name, held in (("int_va", airspeed), ("int_roll", roll), ("int_pitch", pitch)):
            for i in np.flatnonzero(held):
                setattr(self.pids[i], name, 0)
