"""The radiation-search mission: wander, the first detection broadcasts ``found``, everyone
flies there; both engines."""

from __future__ import annotations

import json

import numpy as np
import pyarrow.parquet as pq
import pytest

from pyautonomousagent import Simulation, load
from pyautonomousagent.cli import main
from pyautonomousagent.mission import ScenarioError
from pyautonomousagent.missions.radiation_search import FOUND, leaves
from pyautonomousagent.testing import check_engines_agree, check_leaf


@pytest.fixture(scope="module", params=[0, 3])
def search_run(request) -> Simulation:
    """The scenario as shipped: 4 drones, 2500 iterations (batched; seeds 0 and 3: the source
    is found at iterations 229 and 470)."""
    scenario = load("radiation-search")
    return Simulation.create(scenario, seed=request.param, engine="batched").run(progress=False)


def found_messages(sim: Simulation) -> list[dict]:
    return [e for e in sim.events if e["event"] == "message" and e["type"] == FOUND]


def test_engines_agree_through_the_detection_and_the_flight_to_it():
    assert check_engines_agree(scenario="radiation-search", iterations=400) == 400
    first = found_messages(Simulation.create(load("radiation-search").with_overrides(
        iterations=400), seed=0).run(progress=False))  # fmt: skip
    assert first and first[0]["iteration"] < 300  # the compared run covers the detection


def test_the_first_drone_above_the_threshold_reports_and_no_one_after_it(search_run):
    found = found_messages(search_run)
    assert found, "no drone found the source"
    t0 = found[0]["iteration"]
    assert all(e["iteration"] == t0 for e in found)  # later detections are not reported
    radiation = search_run.recorder.column("radiation")  # every iteration recorded: row = it.
    threshold = search_run.scenario.parameters.radiation_threshold
    sender = search_run.swarm.names.index(found[0]["sender"])
    assert radiation[t0, sender] > threshold
    assert (radiation[:t0] <= threshold).all()
    assert found[0]["receivers"] == "all"


def test_receivers_store_the_reported_position_in_their_next_phase_2(search_run):
    found = found_messages(search_run)
    t0, data = found[0]["iteration"], found[0]["data"]
    reported = search_run.recorder.column("source_reported")
    assert (reported[:t0] == 0).all() and (reported[t0 + 1 :] == 1).all()
    for key in ("x", "y"):
        stored = search_run.recorder.column(f"{key}_reported_position")[t0 + 1 :]
        assert (stored == data[key]).all()
    source = search_run.scenario.objects.radiation_source
    threshold = search_run.scenario.parameters.radiation_threshold
    detection_radius = source.range * (1 - threshold / 100)
    step = search_run.scenario.parameters.search_speed
    assert np.hypot(data["x"] - source.x, data["y"] - source.y) < detection_radius + step


def test_every_drone_reaches_the_reported_position_and_stays(search_run):
    found = found_messages(search_run)[0]
    x, y = search_run.recorder.column("x"), search_run.recorder.column("y")
    distance = np.hypot(x - found["data"]["x"], y - found["data"]["y"])
    tolerance = search_run.scenario.parameters.source_tolerance
    after = distance[found["iteration"] + 1 :]
    assert (after.min(axis=0) <= tolerance).all()
    assert (distance[-1] <= tolerance).all(), distance[-1]
    assert (distance[found["iteration"]] > tolerance).sum() >= 2  # most were far away


def test_drones_wander_inside_the_world_with_seeded_randomness(search_run):
    width, height = search_run.scenario.world
    x, y = search_run.recorder.column("x"), search_run.recorder.column("y")
    assert x.min() > 0 and x.max() < width and y.min() > 0 and y.max() < height
    short = load("radiation-search").with_overrides(iterations=150)
    tracks = [
        Simulation.create(short, seed=seed, engine="batched").run(progress=False).table()
        for seed in (0, 0, 1)
    ]
    assert tracks[0].equals(tracks[1]) and not tracks[0].equals(tracks[2])


def test_a_drone_that_knows_a_position_keeps_it_others_take_the_first_sender():
    sim = Simulation.create(load("radiation-search"), seed=0)
    bb = sim.swarm.blackboard
    bb["source_reported"][1] = 1
    bb["x_reported_position"][1], bb["y_reported_position"][1] = 1.0, 2.0
    link = sim.world.datalink
    link.send(2, FOUND, {"x": 20.0, "y": 21.0}, (20.0, 21.0))
    link.send(0, FOUND, {"x": 10.0, "y": 11.0}, (10.0, 11.0))
    (delivery,) = link.deliver(sim.swarm.columns["x"], sim.swarm.columns["y"])
    sim.mission.store_reported_position(sim, delivery)
    assert bb["source_reported"].tolist() == [1, 1, 1, 1]
    assert bb["x_reported_position"].tolist() == [20.0, 1.0, 10.0, 10.0]
    assert bb["y_reported_position"].tolist() == [21.0, 2.0, 11.0, 11.0]


@pytest.mark.parametrize(
    "leaf_type",
    [
        leaves.ConditionRadiationAboveThreshold,
        leaves.ConditionSourceReported,
        leaves.ConditionAtReportedPosition,
        leaves.ActionReportSourceS,
        leaves.ActionFlyToReportedPositionA,
        leaves.ActionHoverS,
        leaves.ActionWanderA,
    ],
)
def test_each_leaf_gives_the_same_results_on_both_engines(leaf_type):
    assert check_leaf(leaf_type, scenario="radiation-search") == 60


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"radiation_source": {"x": 70, "y": 5, "range": 3}}, r"world.radiation_source must be"),
        ({"radiation_source": {"x": 7, "y": 5, "range": 0}}, r"radiation_source.range must be"),
        ({"start_positions": [[5, -1]]}, r"world.start_positions\[0\] must be inside the world"),
        ({"wander_period": 0}, r"parameters.wander_period must be a whole number >= 1"),
    ],
)
def test_bad_scenarios_get_one_line_naming_the_field(change, message):
    with pytest.raises(ScenarioError, match=message):
        load("radiation-search").with_overrides(**change)


def test_pyaa_run_writes_identical_data_on_both_engines_and_a_gif(tmp_path):
    tables = []
    for engine in ("pytrees", "batched"):
        out = tmp_path / engine
        argv = ["run", "radiation-search", "--iterations", "300", "--frame-every", "30"]
        assert main([*argv, "--engine", engine, "--out", str(out), "--quiet"]) == 0
        assert (out / "animation.gif").read_bytes()[:6] == b"GIF89a"
        events = json.loads((out / "run.json").read_text())["events"]
        assert [e["type"] for e in events if e["event"] == "message"] == [FOUND]
        tables.append(pq.read_table(out / "states.parquet"))
    assert tables[0].equals(tables[1])
