"""The engines agree on every SIMD level NumPy dispatches to, and so do runs across levels.

NumPy picks its kernels at run time from the CPU's features (AVX-512, AVX2, ...); some, such
as ``arctan2`` and ``hypot``, round differently from one level to the next. This module
runs the same engine comparison in a subprocess with the AVX-512 kernels switched off
(``NPY_DISABLE_CPU_FEATURES``), so a machine with AVX-512 checks both levels.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from pyautonomousagent.arrays import arctan2, bearing

#: The features whose kernels differ (NumPy 2.x names); only those this CPU has can be off.
AVX512_FEATURES = ("X86_V4", "AVX512_ICL", "AVX512_SPR", "AVX512_SKX")

#: Run in a subprocess: the engines on a short patrol and a short gathering (messages), and a
#: digest of each run's data, keyed "scenario/engine".
COMPARE = """
import hashlib, json, numpy as np
from pyautonomousagent import Simulation, load
from pyautonomousagent import jit
from pyautonomousagent.arrays import arctan2
digests = {}
for name, overrides in (("patrol", {"agents": 3, "iterations": 300}),
                        ("gathering", {"iterations": 700, "gathering_iteration": 400})):
    scenario = load(name).with_overrides(**overrides)
    for engine in ("pytrees", "batched") + (("compiled",) if jit.available() else ()):
        sim = Simulation.create(scenario, seed=5, engine=engine).run(progress=False)
        h = hashlib.sha256(json.dumps(sim.events).encode())
        for key in sorted(sim.recorder.columns):
            h.update(key.encode() + np.ascontiguousarray(sim.recorder.column(key)).tobytes())
        digests[name + "/" + engine] = h.hexdigest()
rng = np.random.default_rng(0)
a, b = rng.normal(size=4096), rng.normal(size=4096)
digests["arctan2"] = hashlib.sha256(arctan2(a, b).tobytes()).hexdigest()
print(json.dumps(digests))
"""


def _enabled_avx512() -> list[str]:
    try:
        features = np._core._multiarray_umath.__cpu_features__  # type: ignore[attr-defined]
    except AttributeError:  # NumPy < 2
        return []
    return [name for name in AVX512_FEATURES if features.get(name)]


def run_at_simd_level(
    script: str, disable: str = "", args: tuple[str, ...] = (), env: dict[str, str] | None = None
) -> str:
    """Run ``python -c script`` with the NumPy features ``disable`` names switched off (none:
    this CPU's own level) and this checkout's ``src`` first on the path; its standard output."""
    environment = {**os.environ, **(env or {})}
    environment.pop("NPY_DISABLE_CPU_FEATURES", None)
    if disable:
        environment["NPY_DISABLE_CPU_FEATURES"] = disable
    src = os.path.join(os.path.dirname(__file__), "..", "src")
    environment["PYTHONPATH"] = os.pathsep.join(
        [os.path.abspath(src), environment.get("PYTHONPATH", "")]
    )
    done = subprocess.run(
        [sys.executable, "-c", script, *args],
        env=environment,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


def simd_digests(script: str, disable: str = "") -> dict[str, str]:
    """The JSON object ``script`` prints last, run at the SIMD level ``disable`` leaves."""
    return json.loads(run_at_simd_level(script, disable).strip().splitlines()[-1])


def _digests(disable: str = "") -> dict[str, str]:
    return simd_digests(COMPARE, disable)


def test_arctan2_gives_the_same_bits_for_scalars_and_arrays():
    rng = np.random.default_rng(3)
    y = rng.normal(size=3000) * rng.choice([1e-6, 1.0, 1e6], 3000)
    x = rng.normal(size=3000)
    y[:20], x[10:30] = 0.0, 0.0
    x[40:50] = -(x[40:50] ** 2)
    array = arctan2(y, x)
    scalar = np.array([arctan2(float(a), float(b)) for a, b in zip(y, x, strict=True)])
    assert np.array_equal(array, scalar)
    exact = np.array([math.atan2(a, b) for a, b in zip(y, x, strict=True)])
    assert np.max(np.abs(array - exact)) <= 4 * np.spacing(np.pi)


def test_bearing_points_clockwise_from_north():
    assert bearing(0.0, 0.0, 0.0, 1.0) == 0.0
    assert bearing(0.0, 0.0, 1.0, 0.0) == 90.0
    assert bearing(0.0, 0.0, 0.0, -1.0) == 180.0
    assert bearing(0.0, 0.0, -1.0, 0.0) == 270.0
    assert abs(bearing(0.0, 0.0, 1.0, 1.0) - 45.0) < 1e-12


def test_engines_agree_with_and_without_avx512():
    features = _enabled_avx512()
    here = _digests()
    for name in ("patrol", "gathering"):
        engines = {k: v for k, v in here.items() if k.startswith(name + "/")}
        assert len(set(engines.values())) == 1 and len(engines) >= 2, engines
    if not features:
        pytest.skip("this CPU has no AVX-512: only one SIMD level to test")
    without = _digests(" ".join(features))
    assert without == here  # the same bits on both SIMD levels, every engine alike
