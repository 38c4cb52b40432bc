"""crowded's lattice of surveillance positions stays in the world: a swarm too large for its
world is refused when the scenario is checked, naming the largest that fits, and ``pyaa
bench`` (which cannot set the world's size) grows the world to hold the lattice."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyautonomousagent import bench
from pyautonomousagent.cli import main
from pyautonomousagent.missions.crowded import largest_swarm, layout
from pyautonomousagent.scenarios import load
from pyautonomousagent.simulation.params import ScenarioError
from tests.test_bad_inputs import refused


def circles_inside(
    agents: int, world: tuple[float, float], group_size: int, spacing: float, radius: float
) -> bool:
    """Whether every group's circle of refuelling slots (and so its position, its slots and
    the way between them) lies in [0, width] x [0, height]."""
    _, points = layout(agents, group_size, spacing, radius)
    low, high = points.min(axis=0) - radius, points.max(axis=0) + radius
    return bool((low >= 0.0).all() and high[0] <= world[0] and high[1] <= world[1])


SIDE = st.integers(1, 60).map(lambda k: k * 10.0)  # world units


@settings(max_examples=60, deadline=None)
@given(
    st.tuples(SIDE, SIDE),
    st.integers(1, 8),
    st.sampled_from([5.0, 10.0, 25.0, 60.0]),
    st.sampled_from([0.0, 2.5, 5.0, 12.5]),
)
def test_the_largest_swarm_fits_and_one_drone_more_does_not(world, group_size, spacing, radius):
    radius = min(radius, spacing / 2)
    n = largest_swarm(world, group_size, spacing, radius)
    assert n % group_size == 0  # whole groups: one drone more needs one more position
    assert n == 0 or circles_inside(n, world, group_size, spacing, radius)
    assert not circles_inside(n + 1, world, group_size, spacing, radius)


def test_the_scenario_as_shipped_fits_exactly():
    crowded = load("crowded")
    p = crowded.parameters
    assert largest_swarm(crowded.world, p.group_size, p.point_spacing, p.slot_radius) == 24
    assert crowded.agents == 24


def test_a_swarm_too_large_for_the_world_is_refused_naming_the_largest_that_fits(capsys):
    line = refused(["run", "crowded", "--agents", "100", "--no-gif", "--quiet"], capsys)
    assert "agents must be at most 24" in line, line
    assert "world.size at least [290, 230]" in line, line  # 17 groups: 5 columns, 4 rows
    with pytest.raises(ScenarioError, match="at most 24"):
        load("crowded-avoid").with_overrides(agents=25)
    load("crowded").with_overrides(agents=100, size=[290, 230])  # the size it named: fits


def test_slots_wider_than_half_the_spacing_are_refused(capsys):
    line = refused(["run", "crowded", "--set", "slot_radius=31", "--no-gif", "--quiet"], capsys)
    assert "parameters.slot_radius must be at most point_spacing / 2 (30)" in line, line


def test_the_bench_grows_the_world_to_hold_the_lattice_and_keeps_the_positions():
    case = bench.Case("crowded", "batched", 100_000, 5, 10, parameters="proximity_range=0,"
                      "collision_risk_distance=0")  # fmt: skip
    scenario = bench.case_scenario(case)
    p = scenario.parameters
    assert scenario.agents == 100_000 and p.proximity_range == 0.0
    assert circles_inside(100_000, scenario.world, p.group_size, p.point_spacing, p.slot_radius)
    assert scenario.objects == load("crowded").objects  # the world's objects kept
    shipped = load("crowded").parameters  # the lattice as it is, not squeezed into the world
    assert (p.group_size, p.point_spacing, p.slot_radius) == (
        shipped.group_size, shipped.point_spacing, shipped.slot_radius)  # fmt: skip
    small = bench.case_scenario(bench.Case("crowded", "batched", 12, 5, 10))
    assert small.world == load("crowded").world  # a swarm that fits: the world as it is
    patrol = bench.case_scenario(bench.Case("patrol", "batched", 1000, 5, 10))
    assert patrol.world == load("patrol").world


def test_pyaa_bench_runs_a_swarm_larger_than_the_world_and_says_so(capsys):
    argv = ["bench", "crowded", "--agents", "30", "--iterations", "2", "--engines", "batched"]
    assert main(argv) == 0
    out, err = capsys.readouterr()
    assert "crowded with 30 agents: in a world of 170 x 120 (the scenario's is 120 x 120)" in err
    assert "failed" not in out and any(line.split()[:1] == ["30"] for line in out.splitlines())


def test_pyaa_run_world_gives_a_larger_swarm_the_world_it_needs(tmp_path):
    out = tmp_path / "run"
    argv = ["run", "crowded", "--agents", "100", "--world", "290,230", "--iterations", "3",
            "--no-gif", "--no-replay", "--quiet", "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    scenario = json.loads((out / "run.json").read_text())["scenario"]
    assert scenario["agents"] == 100 and scenario["world"]["size"] == [290.0, 230.0]
