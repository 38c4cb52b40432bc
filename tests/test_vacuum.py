"""The vacuum mission (paper Fig. 2): sonar, stop rule, avoidance, cleaned area, both engines."""

from __future__ import annotations

import numpy as np
import pyarrow.parquet as pq
import pytest

from pyautonomousagent import Simulation, load
from pyautonomousagent.bt import SUCCESS, fallback, leaf, sequence
from pyautonomousagent.cli import main
from pyautonomousagent.mission import ScenarioError
from pyautonomousagent.missions.vacuum import Circle, Rectangle, Room, leaves
from pyautonomousagent.render.animation import draw_frame
from pyautonomousagent.testing import check_engines_agree, check_leaf, make_harness

ITERATIONS = 1500


@pytest.fixture(scope="module", params=[0, 2])
def vacuum_run(request) -> Simulation:
    """Three robots for 1500 iterations in the scenario's room (batched, seeds 0 and 2)."""
    scenario = load("vacuum").with_overrides(agents=3, iterations=ITERATIONS)
    return Simulation.create(scenario, seed=request.param, engine="batched").run(progress=False)


def entered(scenario, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Positions inside (or on) an obstacle or outside the room, checked obstacle by obstacle."""
    width, height = scenario.world
    bad = (x < 0) | (x > width) | (y < 0) | (y > height)
    for o in scenario.objects.obstacles:
        if isinstance(o, Rectangle):
            bad |= (x >= o.x) & (x <= o.x + o.width) & (y >= o.y) & (y <= o.y + o.height)
        else:
            bad |= (x - o.x) ** 2 + (y - o.y) ** 2 <= o.radius**2
    return bad


def test_engines_agree_on_every_node_state_and_blackboard_value():
    assert check_engines_agree(scenario="vacuum", agents=3, iterations=400) == 400


def test_no_robot_ever_enters_an_obstacle_though_they_come_close(vacuum_run):
    x, y = vacuum_run.recorder.column("x"), vacuum_run.recorder.column("y")
    assert not entered(vacuum_run.scenario, x, y).any()
    sonar = vacuum_run.recorder.column("sonar")
    assert sonar[0].min() > 1.0  # the first reading, at the start positions
    assert sonar.min() < 0.2  # the robots did drive up to walls and obstacles
    avoiding = vacuum_run.recorder.column("vacuuming")[1:] == 0
    assert avoiding.any() and not avoiding.all()


def test_the_stop_rule_alone_keeps_robots_out_when_the_tree_never_avoids():
    blind = sequence("blind", leaf("Action_Navigate_S", "navigate"), leaf("Action_Vacuum_S", "v"))
    scenario = load("vacuum").with_overrides(agents=4, iterations=300)
    sim = Simulation.create(scenario, seed=1, engine="batched", tree=blind).run(progress=False)
    x, y = sim.recorder.column("x"), sim.recorder.column("y")
    assert not entered(scenario, x, y).any()
    # each drove into something and stays there (it may only turn while avoiding)
    assert (x[-50:] == x[-1]).all() and (y[-50:] == y[-1]).all()


def test_the_cleaned_area_grows_monotonically_and_substantially(vacuum_run):
    total = vacuum_run.recorder.column("cleaned_cells").sum(axis=1)
    assert (np.diff(total) >= 0).all()
    every_300 = total[::300]
    assert (np.diff(every_300) > 0).all(), every_300
    free = int(vacuum_run.mission.grid.free.sum())
    assert total[-1] == vacuum_run.mission.grid.cleaned.sum()
    assert vacuum_run.mission.grid.coverage() == pytest.approx(total[-1] / free)
    assert vacuum_run.mission.grid.coverage() > 0.6


def test_the_animation_draws_the_area_cleaned_so_far(vacuum_run):
    drawer = vacuum_run.scenario.create_mission()  # a fresh instance, as the animation has
    counts = vacuum_run.recorder.column("cleaned_cells").sum(axis=1)
    for row in (0, 1, 400, ITERATIONS):  # rows in order, as frames are drawn
        cells = drawer.frame_marks(vacuum_run.recorder, row)
        assert len(cells) == counts[row]  # the cells cleaned by then, exactly
        assert {m.legend for m in cells} <= {"cleaned area"}
    cell = vacuum_run.scenario.parameters.cell_size
    drawn = {(round(m.x / cell), round(m.y / cell)) for m in cells}
    rows, cols = np.nonzero(vacuum_run.mission.grid.cleaned)
    assert drawn == set(zip(cols.tolist(), rows.tolist(), strict=True))
    assert len(drawer.frame_marks(vacuum_run.recorder, 10)) == counts[10]  # backwards too
    frame = np.asarray(draw_frame(vacuum_run.recorder, vacuum_run.scenario, ITERATIONS))
    light_green = (frame[..., 0] == 0xC7) & (frame[..., 1] == 0xE9) & (frame[..., 2] == 0xC0)
    assert light_green.sum() > 1000  # the cleaned cells are on the picture


def test_the_sonar_reads_the_nearest_wall_or_obstacle_ahead():
    room = Room(10.0, 10.0, (Rectangle(4.0, 4.0, 2.0, 2.0), Circle(8.0, 2.0, 1.0)))
    x = np.array([5.0, 5.0, 2.0, 2.0, 5.0, 9.5])
    y = np.array([1.0, 1.0, 2.0, 2.0, 4.0, 9.0])
    heading = np.array([0.0, 180.0, 90.0, 270.0, 0.0, 45.0])
    expected = [3.0, 1.0, 4.0, 2.0, 0.0, 0.5 * 2**0.5]  # rect, wall, circle (range 4), wall,
    np.testing.assert_allclose(room.sonar(x, y, heading, 4.0), expected, atol=1e-12)
    assert room.sonar(np.array([2.0]), np.array([2.0]), np.array([90.0]), 9.0)[0] == (
        pytest.approx(5.0)
    )  # the circle, once in range
    inside = room.blocked(np.array([5.0, 8.5, 3.9, 10.1]), np.array([5.0, 2.0, 3.9, 5.0]))
    assert inside.tolist() == [True, True, False, True]


def test_avoid_turns_left_or_right_by_whole_turn_steps_and_keeps_its_turn():
    tree = fallback(
        "root",
        sequence(
            "avoid", leaf("Condition_Collision", "near"), leaf("Action_Avoid_Obstacle_S", "a")
        ),
        leaf("Action_Navigate_S", "navigate"),
    )
    h = make_harness(tree, agents=200, scenario="vacuum")
    h.swarm.columns["heading"][:] = 0.0
    h.swarm.blackboard["cruise_heading"][:] = 0.0
    h.swarm.columns["sonar"][:] = 0.5
    h.tick()
    turn = h.swarm.blackboard["cruise_heading"].copy()
    signed = np.where(turn > 180.0, turn - 360.0, turn)
    assert (np.abs(signed) >= 90.0).all() and (np.abs(signed) <= 180.0).all()
    assert (signed % 10.0 == 0.0).all()  # whole multiples of the scenario's turn_step
    assert (signed > 0).any() and (signed < 0).any()  # both sides occur
    assert (h.swarm.columns["requested_speed"] == 0.0).all()
    h.tick()  # mid-turn (heading still 0): the turn in progress is kept
    np.testing.assert_array_equal(h.swarm.blackboard["cruise_heading"], turn)
    h.swarm.columns["sonar"][:] = 3.0
    h.tick()  # clear ahead: navigate on the new cruise heading
    np.testing.assert_array_equal(h.swarm.columns["requested_heading"], turn)
    assert h.statuses()["navigate"] == SUCCESS


@pytest.mark.parametrize(
    "leaf_type",
    [
        leaves.ConditionCollision,
        leaves.ActionAvoidObstacleS,
        leaves.ActionNavigateS,
        leaves.ActionVacuumS,
    ],
)
def test_each_leaf_gives_the_same_results_on_both_engines(leaf_type):
    assert check_leaf(leaf_type, scenario="vacuum") == 60


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"start_positions": [[6, 4]]}, r"world.start_positions\[0\] must be a point clear"),
        ({"obstacles": [{"shape": "square", "x": 1}]}, r"world.obstacles\[0\].shape must be"),
        ({"obstacles": [{"shape": "circle", "x": 1, "y": 1}]}, r"missing key 'world.obstac"),
        ({"collision_distance": 0.1}, r"parameters.collision_distance must be a number > rob"),
        ({"avoid_min_angle": 200, "avoid_max_angle": 100}, r"avoid_min_angle must be <="),
        ({"cell_size": 0.0}, r"parameters.cell_size must be a number > 0"),
    ],
)
def test_bad_scenarios_get_one_line_naming_the_field(change, message):
    with pytest.raises(ScenarioError, match=message):
        load("vacuum").with_overrides(**change)


def test_pyaa_run_writes_identical_data_on_both_engines_and_a_gif(tmp_path, capsys):
    tables = []
    for engine in ("pytrees", "batched"):
        out = tmp_path / engine
        argv = ["run", "vacuum", "--iterations", "150", "--engine", engine, "--out", str(out)]
        assert main([*argv, "--quiet"]) == 0
        assert (out / "animation.gif").read_bytes()[:6] == b"GIF89a"
        tables.append(pq.read_table(out / "states.parquet"))
    assert tables[0].num_rows == 151 * 2
    assert {"sonar", "vacuuming", "cleaned_cells", "cruise_heading"} <= set(tables[0].column_names)
    assert tables[0].equals(tables[1])


def test_pyaa_scenarios_lists_both_new_missions(capsys):
    assert main(["scenarios"]) == 0
    listed = [line.split()[0] for line in capsys.readouterr().out.splitlines()]
    assert {"vacuum", "radiation-search"} <= set(listed)
    assert main(["scenarios", "vacuum"]) == 0
    shown = capsys.readouterr().out
    assert "obstacles" in shown and "collision_distance" in shown and "robot1.." in shown
