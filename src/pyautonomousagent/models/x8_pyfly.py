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
    return {
        "roll": 0.0,
        "pitch": 0.0,
        "yaw": float(np.radians(heading)),
        "omega_p": 0.0,
        "omega_q": 0.0,
        "omega_r": 0.0,
        "position_n": float(y),
        "position_e": float(x),
        "position_d": -settings.initial_altitude,
        "velocity_u": settings.initial_airspeed,
        "velocity_v": 0.0,
        "velocity_w": 0.0,
        "elevon_left": (0.0, 0.0),
        "elevon_right": (0.0, 0.0),
        "throttle": (0.0, 0.0),
        "wind": (0.0, 0.0, 0.0),
    }


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
        self.flight = self._observe()
        self.write(s)

    def advance(self, s: dict[str, np.ndarray], moving: np.ndarray) -> None:
        """Phase 2: one PyFly step per agent where ``moving``.

        Raises:
            FlightEnvelopeError: PyFly refused a step (a state left its constraints).
        """
        for i in np.flatnonzero(moving):
            ok, info = self.aircraft[i].step(self.commands[i].copy())
            if not ok:
                raise FlightEnvelopeError(f"agent {i}: PyFly stopped the step: {info}")
        self.steps += 1
        if self.steps % HISTORY_KEPT == 0:
            for aircraft in self.aircraft:
                _trim_history(aircraft)
        self.flight = self._observe()
        self.write(s, moving)

    def _observe(self) -> Flight:
        names = ["position_n", "position_e", "position_d", "Va", "roll", "pitch", "omega_p"]
        names += ["omega_q", "velocity_u", "velocity_v", "velocity_w"]
        values = np.array([a.get_states_vector(names) for a in self.aircraft], dtype=float).T
        north, east, down, airspeed, roll, pitch, p, q, u, v, w = values
        quaternion = np.array([a.state["attitude"].value for a in self.aircraft], dtype=float).T
        velocity = body_to_ned(quaternion, u, v, w)
        return Flight(
            north=north,
            east=east,
            altitude=-down,
            airspeed=airspeed,
            course=np.arctan2(velocity[1], velocity[0]),
            roll=roll,
            pitch=pitch,
            p=p,
            q=q,
        )

    def _attitude(self, refs: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
        f = self.flight
        roll_ref, pitch_ref, airspeed_ref = refs
        for i, pid in enumerate(self.pids):
            pid.set_reference(phi=roll_ref[i], theta=pitch_ref[i], va=airspeed_ref[i])
            self.commands[i] = pid.get_action(
                f.roll[i], f.pitch[i], f.airspeed[i], [f.p[i], f.q[i]]
            )
