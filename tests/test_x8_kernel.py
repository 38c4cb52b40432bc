"""The compiled X8 kernel gives the same bits as the NumPy reference.

With numba installed the kernel is compiled; with ``PYAA_NO_JIT=1`` it runs as plain Python
(the same comparisons, smaller sizes): either way it must equal the NumPy code bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("pyfly", reason="needs the [x8] extra (pyfly-fixed-wing)")

from pyautonomousagent import Simulation, jit, load  # noqa: E402
from pyautonomousagent.arrays import arctan2  # noqa: E402
from pyautonomousagent.models import x8_dynamics as dyn  # noqa: E402
from pyautonomousagent.models import x8_kernel as kernel  # noqa: E402
from pyautonomousagent.models.x8 import PYTHON_KERNEL_AGENTS, X8Settings, X8Vectorised  # noqa: E402
from tests.test_simd_levels import _enabled_avx512, run_at_simd_level  # noqa: E402

#: Agents and iterations of the model comparison: compiled, or plain Python (slow).
AGENTS, ITERATIONS = (40, 1500) if jit.available() else (4, 60)


def test_scalar_arctangent_and_exponential_equal_the_array_versions():
    rng = np.random.default_rng(3)
    y = np.concatenate([rng.normal(size=3000) * 10.0 ** rng.integers(-3, 3, 3000), [0.0, -0.0]])
    x = np.concatenate([rng.normal(size=3000), [-0.0, 0.0]])
    got = np.array([kernel.atan2(a, b) for a, b in zip(y.tolist(), x.tolist(), strict=True)])
    assert np.array_equal(got, arctan2(y, x))
    assert np.array_equal(np.signbit(got), np.signbit(arctan2(y, x)))
    z = np.concatenate([rng.uniform(-60, 60, 3000), [0.0, -800.0, 800.0]])
    got = np.array([kernel.exp(v) for v in z.tolist()])
    assert np.array_equal(got, dyn.exp(z))


def test_exponential_and_arcsine_are_within_a_few_ulp_of_the_library():
    rng = np.random.default_rng(4)
    z = rng.uniform(-700, 700, 20000)
    want = np.array([math.exp(v) for v in z.tolist()])
    np.testing.assert_allclose(dyn.exp(z), want, rtol=4e-15, atol=0)
    s = rng.uniform(-1, 1, 20000)
    want = np.array([math.asin(v) for v in s.tolist()])
    np.testing.assert_allclose(dyn.arcsin(s), want, rtol=1e-15, atol=1e-16)


def test_wrap_matches_numpy_mod():
    rng = np.random.default_rng(5)
    a = np.concatenate([rng.uniform(-20, 20, 5000), [0.0, -0.0, 2 * math.pi, -math.pi]])
    got = np.array([kernel._mod(v, 2 * math.pi) for v in a.tolist()])
    assert np.array_equal(got, np.mod(a, 2 * math.pi))


def _columns(rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
    return {
        "x": rng.uniform(0, 1000, n),
        "y": rng.uniform(0, 1000, n),
        "heading": rng.uniform(0, 360, n),
        "speed": np.zeros(n),
        "requested_heading": rng.uniform(0, 360, n),
        "requested_speed": np.where(rng.uniform(size=n) < 0.2, 0.0, 22.0),
    }


def test_compiled_model_equals_numpy_model_over_many_iterations_and_uavs():
    rng = np.random.default_rng(6)
    start = _columns(rng, AGENTS)
    settings = X8Settings(initial_altitude=10.0)
    columns = [{k: v.copy() for k, v in start.items()} for _ in range(2)]
    pairs = zip(columns, (True, False), strict=True)
    models = [X8Vectorised(settings, s, agent_by_agent=c) for s, c in pairs]
    assert models[0].agent_by_agent and not models[1].agent_by_agent
    for i in range(ITERATIONS):
        moving = rng.uniform(size=AGENTS) > 0.02  # a few held now and then
        if i % 300 == 0:  # new headings and speeds: turns, climbs, refuelling floors
            new = _columns(rng, AGENTS)
            for s in columns:
                s["requested_heading"][:] = new["requested_heading"]
                s["requested_speed"][:] = new["requested_speed"]
        for model, s in zip(models, columns, strict=True):
            model.advance(s, moving)
            model.control(s)
        compiled, reference = models
        assert np.array_equal(compiled.state, reference.state), i
        assert np.array_equal(compiled.commands, reference.commands), i
    for key in ("x", "y", "speed", "heading"):
        assert np.array_equal(columns[0][key], columns[1][key])
    assert np.array_equal(compiled.attitude.integral, reference.attitude.integral)
    assert np.array_equal(compiled.guidance.course.previous, reference.guidance.course.previous)


def test_the_kernel_runs_compiled_where_numba_is_available_else_for_a_few_agents(monkeypatch):
    rng = np.random.default_rng(7)
    many = PYTHON_KERNEL_AGENTS + 1
    model = X8Vectorised(X8Settings(), _columns(rng, many))
    assert model.compiled == model.agent_by_agent == jit.available()
    monkeypatch.setenv("PYAA_NO_JIT", "1")
    assert not X8Vectorised(X8Settings(), _columns(rng, many)).agent_by_agent
    few = X8Vectorised(X8Settings(), _columns(rng, PYTHON_KERNEL_AGENTS))
    assert few.agent_by_agent and not few.compiled


def test_x8_patrol_records_the_same_bits_compiled_and_not(monkeypatch):
    scenario = load("x8-patrol").with_overrides(agents=5, iterations=400)
    runs = []
    for no_jit in ("0", "1"):
        monkeypatch.setenv("PYAA_NO_JIT", no_jit)
        sim = Simulation.create(scenario, seed=2, engine="batched")
        assert sim.model.agent_by_agent == (no_jit == "0" and jit.available())
        runs.append(sim.run(progress=False).recorder)
    compiled, reference = runs
    assert sorted(compiled.columns) == sorted(reference.columns)
    for key in compiled.columns:
        assert np.array_equal(compiled.column(key), reference.column(key)), key


#: Run in a subprocess: the records of an x8-patrol run and of a landing cycle (x8-landing
#: through touchdown, roll-out, refuelling, take-off roll and rotation), digested.
DIGEST = """
import hashlib, sys
import numpy as np
from pyautonomousagent import Simulation, load
h = hashlib.sha256()
for name, agents, iterations in (("x8-patrol", 5, 300), ("x8-landing", 2, 2600)):
    scenario = load(name).with_overrides(agents=agents, iterations=iterations)
    sim = Simulation.create(scenario, seed=1, engine="batched").run(progress=False)
    assert sim.model.compiled == (sys.argv[1] == "compiled"), sim.model.compiled
    for key in sorted(sim.recorder.columns):
        h.update(key.encode() + np.ascontiguousarray(sim.recorder.column(key)).tobytes())
print(h.hexdigest())
"""


def _digest(mode: str, disable: str = "") -> str:
    env = {"PYAA_NO_JIT": "1" if mode == "numpy" else "0"}
    return run_at_simd_level(DIGEST, disable, (mode,), env).strip().splitlines()[-1]


@pytest.mark.skipif(not jit.available(), reason="needs numba (the [fast] extra)")
def test_compiled_run_equals_the_numpy_run_on_every_simd_level():
    reference = _digest("numpy")
    assert _digest("compiled") == reference
    features = _enabled_avx512()
    if features:  # NumPy's kernels change with the level; the model's bits must not
        assert _digest("numpy", " ".join(features)) == reference


def test_a_kernel_that_disagrees_is_not_used(monkeypatch, caplog):
    pack = kernel.pack_constants

    def stale(k: dyn.Constants) -> np.ndarray:  # as if compiled with an older constant
        packed = pack(k)
        packed[kernel.QBAR] *= 1.0 + 1e-12
        return packed

    monkeypatch.setattr(kernel, "pack_constants", stale)
    model = X8Vectorised(X8Settings(), _columns(np.random.default_rng(8), 5), agent_by_agent=True)
    assert not model.agent_by_agent and not model.compiled
    assert "does not give the NumPy code's bits" in caplog.text
