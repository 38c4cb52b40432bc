"""testing.check_same_runs: two finished runs recorded the same bits, or the first difference."""

from __future__ import annotations

import numpy as np
import pytest

from pyautonomousagent import Simulation, load
from pyautonomousagent.testing import check_same_runs


def _run(engine: str = "batched") -> Simulation:
    scenario = load("gathering").with_overrides(iterations=60, gathering_iteration=20)
    return Simulation.create(scenario, seed=1, engine=engine).run(progress=False)


def test_the_same_run_twice_passes() -> None:
    check_same_runs(_run(), _run("pytrees"), ("batched", "pytrees"))


def test_a_flipped_bit_a_sign_of_zero_and_an_event_are_named() -> None:
    a, b = _run(), _run()
    energy = b.recorder.columns["energy"]
    energy[5, 2] = np.nextafter(energy[5, 2], 0.0)  # one ulp
    with pytest.raises(AssertionError, match=r"energy differs first at \(5, 2\)"):
        check_same_runs(a, b)
    energy[5, 2] = a.recorder.columns["energy"][5, 2]
    heading = b.recorder.columns["heading"]
    zero = np.flatnonzero(heading[:, 0] == 0.0)[0]
    heading[zero, 0] = -0.0  # equal as numbers, not as bits
    with pytest.raises(AssertionError, match=rf"heading differs first at \({zero}, 0\)"):
        check_same_runs(a, b)
    heading[zero, 0] = 0.0
    b.recorder.traces[3, 0, 0] += 1
    with pytest.raises(AssertionError, match=r"traces differs first at \(3, 0, 0\)"):
        check_same_runs(a, b)
    b.recorder.traces[3, 0, 0] -= 1
    check_same_runs(a, b)
    b.events.append({"iteration": 60, "event": "extra"})
    with pytest.raises(AssertionError, match="events differ first at 1 of 1"):
        check_same_runs(a, b, ("a", "b"))
