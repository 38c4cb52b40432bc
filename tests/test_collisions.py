"""Collisions (issue 18, part 2): the cell list against all pairs, collisions on entry, the
crowded scenarios with and without avoidance, the engines alike (both SIMD levels), bad
input, and what ``pyaa run`` and ``pyaa bench --compare`` say."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from pyautonomousagent import bench, jit
from pyautonomousagent.arrays import bearing
from pyautonomousagent.bt.leaf import leaf_type
from pyautonomousagent.bt.status import FAILURE, RUNNING, SUCCESS
from pyautonomousagent.cli import main
from pyautonomousagent.datalink import grid_pairs
from pyautonomousagent.missions.crowded.collisions import Collisions, bearings
from pyautonomousagent.proximity import CellList
from pyautonomousagent.scenarios import load
from pyautonomousagent.simulation import Simulation
from pyautonomousagent.testing import check_leaf
from tests.test_bad_inputs import refused
from tests.test_simd_levels import _enabled_avx512, simd_digests

DEFAULTS = vars(load("crowded").parameters)
CROWDED = Path(load("crowded").tree).parent / "crowded.yaml"

# ------------------------------------------------------------------ the grid against all pairs


def swarms(dimensions: int) -> st.SearchStrategy[tuple[np.ndarray, float, float, float]]:
    """Points (d, N) on a lattice of quarter-reach steps (so many lie exactly on cell edges,
    coincide, or lie exactly ``reach`` apart) in a world [0, 10] per axis (its borders
    included), some anywhere in it; a reach, a range and a radius (both at most reach)."""
    lattice = st.integers(0, 40).map(lambda k: k * 0.25)  # 0 .. 10, the world's borders too
    anywhere = st.floats(0.0, 10.0, allow_nan=False)
    coordinate = st.one_of(lattice, lattice, anywhere, st.sampled_from([0.0, 10.0]))
    point = st.tuples(*[coordinate] * dimensions)
    return st.tuples(
        st.lists(point, min_size=0, max_size=40).map(
            lambda ps: np.array(ps, dtype=np.float64).reshape(-1, dimensions).T.copy()
        ),
        st.sampled_from([0.25, 0.5, 1.0, 2.5, 10.0]),
        st.sampled_from([0.0, 0.25, 0.5, 1.0]),
        st.sampled_from([0.0, 0.25, 0.5, 1.0]),
    )


def all_pairs_squared(points: np.ndarray) -> np.ndarray:
    """Squared distances of every pair, (N, N), summed axis by axis as the grid does."""
    total = np.zeros((points.shape[1], points.shape[1]))
    for axis in points:
        delta = axis[None, :] - axis[:, None]
        total += delta * delta
    return total


@settings(max_examples=300, deadline=None)
@given(st.one_of(swarms(2), swarms(3)))
def test_the_grid_finds_what_all_pairs_find(swarm):
    points, reach, range_fraction, radius_fraction = swarm
    range_, radius = reach * range_fraction, reach * radius_fraction
    n = points.shape[1]
    near = CellList(points, reach).near(range_, radius)
    d2 = all_pairs_squared(points)
    np.fill_diagonal(d2, np.inf)
    for i in range(n):  # nearest within range, the lowest index among equals
        within = np.flatnonzero(d2[i] <= range_ * range_)
        if within.size == 0:
            assert near.nearest[i] == -1 and near.distance[i] == np.inf
        else:
            best = within[d2[i, within] == d2[i, within].min()][0]
            assert near.nearest[i] == best
            assert near.distance[i] == np.sqrt(d2[i, best])
    first, second = np.nonzero(np.triu(d2 < radius * radius, 1))
    assert np.array_equal(near.first, first) and np.array_equal(near.second, second)
    assert np.array_equal(near.pair_distance, np.sqrt(d2[first, second]))
    # the datalink's query: every (query, point) pair within reach is a candidate
    query, found = CellList(points, reach).candidates(points[:, : n // 2] + 0.125)
    candidates = set(zip(query.tolist(), found.tolist(), strict=True))
    shifted = points[:, : n // 2] + 0.125
    for q in range(shifted.shape[1]):
        gap = ((points - shifted[:, q : q + 1]) ** 2).sum(axis=0)
        for j in np.flatnonzero(gap <= reach * reach):
            assert (q, int(j)) in candidates


@settings(max_examples=100, deadline=None)
@given(swarms(2))
def test_datalink_grid_pairs_are_the_pairs_in_range(swarm):
    points, reach, _, _ = swarm
    x, y = points
    rows = np.arange(x.size)
    receivers, messages = grid_pairs(x, y, rows, x, y, reach)
    expected = {
        (int(r), int(m))
        for m in rows
        for r in np.flatnonzero(np.hypot(x - x[m], y - y[m]) <= reach)
    }
    assert set(zip(receivers.tolist(), messages.tolist(), strict=True)) == expected
    assert len(expected) == receivers.size  # no pair twice


#: Run in a subprocess with and without numba: the grid's answers on fixed swarms.
PLAIN = """
import json, numpy as np
from pyautonomousagent.proximity import CellList
rng = np.random.default_rng(8)
out = []
for d in (2, 3):
    points = np.round(rng.uniform(0, 6, size=(d, 300)) * 4) / 4
    near = CellList(points, 1.0).near(1.0, 0.5)
    q, p = CellList(points, 1.0).candidates(points[:, :40])
    out.append([near.nearest.tolist(), near.distance.tolist(), near.first.tolist(),
                near.second.tolist(), sorted(zip(q.tolist(), p.tolist()))])
print(json.dumps(out))
"""


def test_the_grid_gives_the_same_answers_compiled_or_not():
    src = Path(__file__).parent.parent / "src"
    path = os.pathsep.join([str(src.resolve()), os.environ.get("PYTHONPATH", "")])
    runs = [
        subprocess.run([sys.executable, "-c", PLAIN], capture_output=True, text=True,
                       env={**os.environ, "PYTHONPATH": path, "PYAA_NO_JIT": flag}, timeout=600)
        for flag in ("0", "1")
    ]  # fmt: skip
    assert all(r.returncode == 0 for r in runs), runs[0].stderr[-2000:] + runs[1].stderr[-2000:]
    assert json.loads(runs[0].stdout) == json.loads(runs[1].stdout)


def test_a_sparse_world_needs_no_array_of_its_area():
    x = np.array([0.0, 1e9, 1e9 + 0.5, -3e8])
    near = CellList((x, np.zeros(4), x), 1.0).near(1.0, 1.0)
    assert near.nearest.tolist() == [-1, 2, 1, -1]
    assert near.first.tolist() == [1] and near.second.tolist() == [2]


# ------------------------------------------------------------------------- collisions


def test_a_pair_that_stays_within_the_radius_collides_once_per_entry():
    track = Collisions(agents=3, radius=1.0, sensor_range=2.0)
    gaps = [5.0, 0.5, 0.2, 0.9, 1.0, 0.99, 3.0, 0.0]  # agent 1's distance from agent 0
    new = []
    for gap in gaps:
        reading = track.sense((np.array([0.0, gap, 50.0]), np.zeros(3)))
        new.append(list(zip(reading.first.tolist(), reading.second.tolist(), strict=True)))
    # entries: at 0.5 (in), 0.2 and 0.9 (still in), 1.0 (out: not closer than the radius),
    # 0.99 (in again), 3.0 (out), 0.0 (in again)
    assert new == [[], [(0, 1)], [], [], [], [(0, 1)], [], [(0, 1)]]
    assert reading.distance.tolist() == [0.0, 0.0, 2.0]  # agent 2 sees nothing: the range
    assert reading.bearing[0] == 90.0 or reading.distance[0] == 0.0


def test_the_proximity_sensor_reads_distance_and_bearing_clockwise_from_north():
    track = Collisions(agents=3, radius=0.0, sensor_range=5.0)
    reading = track.sense((np.array([0.0, 0.0, 3.0]), np.array([0.0, 2.0, 0.0])))
    assert reading.distance.tolist() == [2.0, 2.0, 3.0]
    assert reading.bearing.tolist() == [0.0, 180.0, 270.0]  # north, south, west


def test_the_sensor_bearings_are_the_bits_of_arrays_bearing():
    rng = np.random.default_rng(4)
    x, y = rng.normal(size=(2, 5000)) * rng.choice([1e-3, 1.0, 1e3], size=(2, 5000))
    nearest = rng.integers(-1, 5000, size=5000)
    out = np.empty(5000)
    bearings(x, y, nearest, out)
    found = nearest >= 0
    expected = bearing(x[found], y[found], x[nearest[found]], y[nearest[found]])
    assert np.array_equal(out[found], expected) and not out[~found].any()


def _collisions(sim: Simulation) -> list[dict]:
    return [e for e in sim.events if e["event"] == "collision"]


@pytest.fixture(scope="module")
def crowded_runs() -> dict[str, Simulation]:
    return {
        name: Simulation.create(load(name), engine="batched").run(progress=False)
        for name in ("crowded", "crowded-avoid")
    }


def test_crowded_collides_without_avoidance_and_never_with_it(crowded_runs):
    without = len(_collisions(crowded_runs["crowded"]))
    with_avoidance = len(_collisions(crowded_runs["crowded-avoid"]))
    print(f"\ncrowded: {without} collisions over the whole run (tree without avoidance)")
    print(f"crowded-avoid: {with_avoidance} collisions over the whole run (tree with it)")
    assert without > 0
    assert with_avoidance == 0
    assert crowded_runs["crowded-avoid"].recorder.column("collisions").max() == 0


def test_collisions_are_events_columns_and_damage(crowded_runs):
    sim = crowded_runs["crowded"]
    events = _collisions(sim)
    names = list(sim.swarm.names)
    counts = np.zeros(sim.swarm.size, dtype=np.int64)
    for event in events:
        assert event["agent"] != event["other"] and 0.0 <= event["distance"] < 0.5
        counts[names.index(event["agent"])] += 1
        counts[names.index(event["other"])] += 1
    assert np.array_equal(sim.swarm.columns["collisions"], counts)
    damage = np.minimum(counts * sim.scenario.parameters.collision_damage, 100.0)
    assert np.array_equal(sim.swarm.columns["damage"], damage)  # no radiation: collisions only
    first, recorded = events[0], sim.recorder.column("collisions")  # (records, N), every iteration
    t, i = first["iteration"], names.index(first["agent"])
    assert recorded[t - 1, i] == 0 and recorded[t, i] >= 1
    assert np.array_equal(recorded[-1], counts)


def test_collision_damage_is_a_parameter():
    sim = Simulation.create(
        load("crowded").with_overrides(iterations=400, collision_damage=2.5), engine="batched"
    ).run(progress=False)
    hits = sim.swarm.columns["collisions"]
    assert hits.sum() > 0
    assert np.array_equal(sim.swarm.columns["damage"], hits * 2.5)


def test_radius_and_range_zero_switch_detection_off():
    off = {"collision_radius": 0, "proximity_range": 0, "collision_risk_distance": 0}
    sim = Simulation.create(load("crowded").with_overrides(iterations=400, **off))
    sim.run(progress=False)
    assert not _collisions(sim) and sim.swarm.columns["damage"].max() == 0.0


# ------------------------------------------------------------------------------ leaves


def statuses(result, n: int) -> list[int]:
    return [int(v) for v in np.broadcast_to(result, (n,))]


def test_avoid_turns_away_and_stands_still_while_the_neighbour_is_ahead():
    avoid = leaf_type("Action_Avoid_Collision").create({"speed": 0.1}, DEFAULTS, where="test")
    risk = leaf_type("Condition_Collision_Risk").create({"distance": 2.0}, DEFAULTS, where="t")
    sim = Simulation.create(load("crowded").with_overrides(agents=4, iterations=1))
    s = sim.swarm.columns
    s["heading"][:] = [0.0, 0.0, 350.0, 180.0]
    s["neighbour_bearing"][:] = [80.0, 100.0, 200.0, 10.0]  # ahead, behind, behind, behind
    s["neighbour_distance"][:] = [1.0, 1.99, 2.0, 3.0]
    view = sim.swarm.agents(np.arange(4))
    assert avoid.evaluate(view, sim.world) == RUNNING
    assert s["requested_speed"].tolist() == [0.0, 0.1, 0.1, 0.1]
    assert s["requested_heading"].tolist() == [260.0, 280.0, 20.0, 190.0]
    assert statuses(risk.evaluate(view, sim.world), 4) == [SUCCESS, SUCCESS, FAILURE, FAILURE]
    one = sim.swarm.agents(0)  # one agent (the py_trees engine's call): the same decisions
    s["requested_speed"][:] = -1.0
    assert avoid.evaluate(one, sim.world) == RUNNING and s["requested_speed"][0] == 0.0


@pytest.mark.parametrize("type_name", ["Condition_Collision_Risk", "Action_Avoid_Collision"])
def test_the_proximity_leaves_run_alike_on_both_engines(type_name):
    assert check_leaf(leaf_type(type_name), "crowded", agents=12, iterations=300) == 300


# ------------------------------------------------------------------ engines, SIMD levels

#: Run in a subprocess: crowded with both trees on every engine; a digest of each run.
COMPARE = """
import hashlib, json, numpy as np
from pyautonomousagent import Simulation, load, jit
digests = {}
for name in ("crowded", "crowded-avoid"):
    scenario = load(name).with_overrides(iterations=900)
    for engine in ("pytrees", "batched") + (("compiled",) if jit.available() else ()):
        sim = Simulation.create(scenario, seed=3, engine=engine).run(progress=False)
        h = hashlib.sha256(json.dumps(sim.events).encode())
        for key in sorted(sim.recorder.columns):
            h.update(key.encode() + np.ascontiguousarray(sim.recorder.column(key)).tobytes())
        digests[name + "/" + engine] = h.hexdigest()
        digests[name + "/collisions"] = str(sum(e["event"] == "collision" for e in sim.events))
print(json.dumps(digests))
"""


def test_engines_agree_on_crowded_with_and_without_avx512():
    here = simd_digests(COMPARE)
    engines = 3 if jit.available() else 2
    for name in ("crowded", "crowded-avoid"):
        runs = {k: v for k, v in here.items() if k.startswith(name + "/") and "collisions" not in k}
        assert len(runs) == engines and len(set(runs.values())) == 1, runs
    assert int(here["crowded/collisions"]) > 0 and here["crowded-avoid/collisions"] == "0"
    features = _enabled_avx512()
    if not features:
        pytest.skip("this CPU has no AVX-512: only one SIMD level to test")
    without = simd_digests(COMPARE, " ".join(features))
    for name in ("crowded", "crowded-avoid"):  # engines alike on the other level too
        runs = {k: v for k, v in without.items() if k.startswith(name + "/") and "coll" not in k}
        assert len(runs) == engines and len(set(runs.values())) == 1, runs


# ------------------------------------------------------- the compiled engine's fused loop

needs_numba = pytest.mark.skipif(not jit.available(), reason="the compiled engine needs numba")


def fused_run(scenario, seed: int, **replace_buffers: int) -> tuple[Simulation, int, int]:
    """``scenario`` on the compiled engine, how many of its iterations ran fused and in how
    many calls; ``replace_buffers``: the collision buffers ``touching`` / ``events`` made
    that small."""
    sim = Simulation.create(scenario, seed=seed, engine="compiled")
    assert sim.engine.fuses(sim) and sim.engine.why_not_fused(sim) == ""
    state = sim.mission.collisions
    if "touching" in replace_buffers:
        state.touching = np.zeros(replace_buffers["touching"], dtype=np.int64)
    if "events" in replace_buffers:
        room = replace_buffers["events"]
        state.events = (np.zeros(room, np.int64), np.zeros((2, room), np.int64), np.zeros(room))
    loop, fused, calls = sim.engine.loop, [0], [0]

    def counting(sim: Simulation, count: int, typical: int | None = None) -> int:
        done = loop(sim, count, typical)
        fused[0] += done
        calls[0] += 1
        return done

    sim.engine.loop = counting  # type: ignore[method-assign]
    return sim.run(progress=False), fused[0], calls[0]


def assert_same_crowded_runs(batched: Simulation, compiled: Simulation) -> None:
    from tests.test_compiled_engine import assert_same_runs

    assert_same_runs(batched, compiled)  # events, recorded columns, traces, behaviour
    for key in ("neighbour_distance", "neighbour_bearing", "collisions", "damage", "x"):
        assert np.array_equal(batched.swarm.columns[key], compiled.swarm.columns[key]), key


@needs_numba
@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("name", ["crowded", "crowded-avoid"])
def test_the_compiled_engine_runs_crowded_fused_with_the_batched_bits(name, seed):
    scenario = load(name).with_overrides(iterations=700, initial_heading="random")
    batched = Simulation.create(scenario, seed=seed, engine="batched").run(progress=False)
    compiled, fused, calls = fused_run(scenario, seed)
    assert fused == 700 and calls == 2  # 500 iterations a call at most
    assert_same_crowded_runs(batched, compiled)
    if name == "crowded":  # not vacuous: drones collided, and were seen near
        assert len(_collisions(compiled)) > 0
    else:  # avoidance decided something: a neighbour came within the risk distance
        risk = scenario.parameters.collision_risk_distance
        assert (compiled.recorder.column("neighbour_distance") < risk).any()
        assert not _collisions(compiled)


@needs_numba
@pytest.mark.parametrize("parallel", [True, False])
def test_fused_collisions_with_alerts_and_buffers_too_small_give_the_batched_run(
    monkeypatch, parallel
):
    from pyautonomousagent.engines import compiled

    monkeypatch.setattr(compiled, "PARALLEL_AGENTS", 100 if parallel else 10**9)
    scenario = load("crowded").with_overrides(
        agents=300, iterations=600, energy_use=0.2, low_energy_threshold=1, refuel_rate=0.5,
        size=[470, 410],  # holds the lattice of 50 positions (CrowdedMission.world_for)
    )  # fmt: skip
    batched = Simulation.create(scenario, seed=4, engine="batched").run(progress=False)
    events = [e["event"] for e in batched.events]  # alerts and collisions in the same calls
    assert "alert" in events and events.count("collision") > 8
    run, fused, calls = fused_run(scenario, 4, touching=1, events=2)
    assert fused == 600 and calls > 2  # stopped for room (then made) before an iteration
    assert run.mission.collisions.events[0].size > 2
    assert run.engine._function(run.engine._fused, 1).endswith("_parallel" if parallel else "l")
    assert_same_crowded_runs(batched, run)


# ------------------------------------------------------------------------- the command line


@pytest.mark.parametrize(
    ("key", "value"),
    [("collision_radius", -1.0), ("collision_radius", float("nan")),
     ("proximity_range", -0.5), ("collision_damage", float("nan")),
     ("collision_risk_distance", 4.0)],
)  # fmt: skip
def test_bad_collision_parameters_are_refused(key, value, tmp_path, capsys):
    data = yaml.safe_load(CROWDED.read_text())
    data["parameters"][key] = value
    data["tree"] = str(CROWDED.parent / "crowded.xml")
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    line = refused(["run", str(path), "--no-gif", "--quiet", "--out", str(tmp_path / "o")], capsys)
    assert f"{path.name}: parameters.{key} must be" in line


@needs_numba
def test_pyaa_run_fuses_crowded_on_the_compiled_engine(tmp_path, capsys):
    argv = ["run", "crowded", "--engine", "compiled", "--iterations", "30", "--no-gif",
            "--no-replay", "--out", str(tmp_path / "run")]  # fmt: skip
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "crowded" in out and "the compiled engine ticks the tree only" not in out, out
    summary = json.loads((tmp_path / "run" / "run.json").read_text())
    assert "events" in summary


def test_bench_compares_variants_side_by_side(capsys):
    argv = ["bench", "crowded", "--agents", "30", "--iterations", "5", "--engines", "batched",
            "--compare", "off:collision_radius=0,proximity_range=0,collision_risk_distance=0",
            "--compare", "on:", "--repeat", "2"]  # fmt: skip
    assert main(argv) == 0
    out, err = capsys.readouterr()
    rows = [line.split() for line in out.splitlines() if line.strip().startswith("30 ")]
    assert [row[2] for row in rows] == ["off", "on"]
    assert rows[0][4] == "1.00" and len(rows[1]) == 9  # two repeats' loop times each
    assert err.count("measuring batched off") == 2 and err.count("measuring batched on") == 2


def test_bench_compare_refuses_bad_variants(capsys):
    line = refused(["bench", "crowded", "--compare", "x:collision_radius=-1"], capsys)
    assert "collision_radius" in line
    line = refused(["bench", "crowded", "--compare", "x:collision_radius"], capsys)
    assert "KEY=VALUE" in line
    assert bench.parse_parameters("a=1, b=x") == {"a": 1, "b": "x"}
