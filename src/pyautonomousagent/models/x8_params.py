"""The Skywalker X8's numbers, read at run time from the files ``pyfly-fixed-wing`` ships.

The package (PyPI ``pyfly-fixed-wing`` 0.1.2, optional extra ``[x8]``) installs two data files
beside its code: ``x8_param.mat`` (mass, inertia, geometry, propulsion and the aerodynamic
coefficients of Gryte et al. 2018) and ``pyfly_config.json`` (time step, air density, gravity
and the actuators' limits and dynamics). They are located through
:mod:`importlib.resources` in the installed package, never through the working directory, and
read once per process (:func:`load_parameters` is cached).

Angles are in radians, lengths in metres, masses in kilograms, times in seconds.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, fields
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

#: The distribution that ships the X8 data files, and its import name.
PYFLY_DISTRIBUTION = "pyfly-fixed-wing"
PYFLY_PACKAGE = "pyfly"
PARAMETER_FILE = "x8_param.mat"
CONFIG_FILE = "pyfly_config.json"


class X8UnavailableError(RuntimeError):
    """``pyfly-fixed-wing`` (the ``[x8]`` extra) is not installed."""


def pyfly_file(name: str) -> Path:
    """The path of a data file shipped inside the installed ``pyfly`` package.

    Raises:
        X8UnavailableError: the package is not installed (``pip install "pyautonomousagent[x8]"``).
    """
    try:
        root = resources.files(PYFLY_PACKAGE)
    except ModuleNotFoundError:
        raise X8UnavailableError(
            f"the Skywalker X8 needs the {PYFLY_DISTRIBUTION!r} package: "
            'pip install "pyautonomousagent[x8]"'
        ) from None
    path = Path(str(root / name))
    if not path.is_file():
        raise X8UnavailableError(f"{PYFLY_DISTRIBUTION} is installed but has no {name} ({path})")
    return path


@dataclass(frozen=True)
class Aerodynamics:
    """Aerodynamic coefficients (dimensionless) and the stall model's blending constants.

    Names follow the parameter file: ``C_L_alpha`` is the lift slope per radian, ``C_m_q`` the
    pitch damping, ``M`` and ``a_0`` the sharpness and angle (rad) of the stall blending. The
    rudder's (``*_delta_r``) are not read: the X8 has no rudder.
    """

    C_L_0: float
    C_L_alpha: float
    C_L_q: float
    C_L_delta_e: float
    C_D_p: float
    C_D_q: float
    C_D_delta_e: float
    C_D_beta1: float
    C_D_beta2: float
    C_m_0: float
    C_m_alpha: float
    C_m_q: float
    C_m_delta_e: float
    C_m_fp: float
    C_Y_0: float
    C_Y_beta: float
    C_Y_p: float
    C_Y_r: float
    C_Y_delta_a: float
    C_l_0: float
    C_l_beta: float
    C_l_p: float
    C_l_r: float
    C_l_delta_a: float
    C_n_0: float
    C_n_beta: float
    C_n_p: float
    C_n_r: float
    C_n_delta_a: float
    M: float
    a_0: float
    e: float


@dataclass(frozen=True)
class Airframe:
    """Mass (kg), inertia (kg m^2), geometry (m, m^2) and propulsion of the X8.

    ``k_motor`` (m/s), ``k_T_P`` and ``k_Omega`` are the motor constants of Beard & McLain's
    propeller model; ``S_prop`` (m^2) and ``C_prop`` the propeller's disc area and efficiency.
    """

    mass: float
    Jx: float
    Jy: float
    Jz: float
    Jxz: float
    S_wing: float
    b: float
    c: float
    S_prop: float
    C_prop: float
    k_motor: float
    k_T_P: float  # noqa: N815 (the parameter file's names)
    k_Omega: float  # noqa: N815

    @property
    def aspect_ratio(self) -> float:
        """Wing aspect ratio b^2 / S."""
        return self.b**2 / self.S_wing

    def gammas(self) -> tuple[float, ...]:
        """Beard & McLain's inertia constants Gamma_1..Gamma_8 (eq. 3.13), as a tuple of 8.

        With the product of inertia ``Jxz`` taken positive (the file's value) and
        ``Gamma = Jx Jz - Jxz^2``.
        """
        jx, jy, jz, jxz = self.Jx, self.Jy, self.Jz, self.Jxz
        gamma = jx * jz - jxz**2
        return (
            jxz * (jx - jy + jz) / gamma,
            (jz * (jz - jy) + jxz**2) / gamma,
            jz / gamma,
            jxz / gamma,
            (jz - jx) / jy,
            jxz / jy,
            ((jx - jy) * jx + jxz**2) / gamma,
            jx / gamma,
        )


@dataclass(frozen=True)
class Actuators:
    """The actuators of the configuration file (radians, seconds).

    The two elevons are second-order systems (natural frequency ``omega_0`` rad/s, damping
    ``zeta``) with deflection limits ``[elevon_min, elevon_max]`` and a rate limit
    ``elevon_rate_max`` (rad/s); the throttle is first order with time constant
    ``throttle_tau`` and limits ``[throttle_min, throttle_max]``. Elevator and aileron are
    mixed from the elevons: ``elevator = (right + left) / 2``, ``aileron = (left - right) / 2``.
    """

    elevon_min: float
    elevon_max: float
    elevon_rate_max: float
    omega_0: float
    zeta: float
    throttle_min: float
    throttle_max: float
    throttle_tau: float


@dataclass(frozen=True)
class X8Parameters:
    """Everything the X8 model reads from the package's data files.

    Attributes:
        aero: aerodynamic coefficients.
        airframe: mass, inertia, geometry, propulsion.
        actuators: actuator limits and dynamics.
        rho: air density (kg/m^3).
        g: gravitational acceleration (m/s^2).
        dt: the simulator's time step (s).
        airspeed_min: the smallest airspeed used in the aerodynamic terms (m/s).
        source: the parameter file read.
    """

    aero: Aerodynamics
    airframe: Airframe
    actuators: Actuators
    rho: float
    g: float
    dt: float
    airspeed_min: float
    source: str


def _pick(cls: type, values: dict[str, Any]) -> Any:
    """An instance of the dataclass ``cls`` with its fields taken from ``values`` as floats."""
    missing = [f.name for f in fields(cls) if f.name not in values]
    if missing:
        raise X8UnavailableError(f"the X8 parameter file lacks {', '.join(missing)}")
    return cls(**{f.name: float(values[f.name]) for f in fields(cls)})


def _variables(config: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """The configuration's variables by name, angles converted to radians where it says so.

    Only the limits and initial ranges are given in degrees; ``dot_max`` (the actuators' rate
    limit) is given in rad/s already (3.4907 rad/s = 200 deg/s) and PyFly reads it so.
    """
    import math

    out: dict[str, dict[str, Any]] = {}
    for var in config["variables"]:
        entry = dict(var)
        if entry.get("convert_to_radians"):
            for key in ("value_min", "value_max", "init_min", "init_max"):
                if entry.get(key) is not None:
                    entry[key] = math.radians(entry[key])
        out[entry["name"]] = entry
    return out


def _actuators(config: dict[str, Any]) -> Actuators:
    v = _variables(config)
    right, left, throttle = v["elevon_right"], v["elevon_left"], v["throttle"]
    elevon = ("value_min", "value_max", "dot_max", "omega_0", "zeta")  # Actuators' field order
    for key in elevon:
        if right.get(key) != left.get(key):
            raise X8UnavailableError(
                f"the two elevons differ in {key}; this model needs them equal"
            )
    values = [right[key] for key in elevon]
    values += [throttle[key] for key in ("value_min", "value_max", "tau")]
    return Actuators(*map(float, values))


@lru_cache(maxsize=1)
def load_parameters() -> X8Parameters:
    """The X8's parameters from the installed package's ``x8_param.mat`` and config (cached).

    Raises:
        X8UnavailableError: ``pyfly-fixed-wing`` or SciPy (its dependency) is not installed.
    """
    mat_path, config_path = pyfly_file(PARAMETER_FILE), pyfly_file(CONFIG_FILE)
    try:
        from scipy.io import loadmat
    except ModuleNotFoundError:  # pragma: no cover - scipy comes with pyfly-fixed-wing
        raise X8UnavailableError("reading the X8 parameter file needs SciPy") from None
    values = {k: v for k, v in loadmat(str(mat_path), squeeze_me=True).items() if k[0] != "_"}
    config = json.loads(config_path.read_text())
    airspeed = _variables(config).get("Va", {})
    return X8Parameters(
        aero=_pick(Aerodynamics, values),
        airframe=_pick(Airframe, values),
        actuators=_actuators(config),
        rho=float(config["rho"]),
        g=float(config["g"]),
        dt=float(config["dt"]),
        airspeed_min=float(airspeed.get("value_min") or 1e-6),
        source=str(mat_path),
    )
