"""The GPU engine with messages (issue 20): gathering's and radiation-search's kernels (the
datalink on the device) run through numba's CUDA simulator against the batched engine, bit
for bit, with the messages reaching everyone and reaching only some; the generated source on
the CPU."""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from pyautonomousagent import Simulation, jit, load
from pyautonomousagent.engines.gpu_messages import DeviceMessages
from pyautonomousagent.engines.gpu_source import Thread, message_module_source
from pyautonomousagent.loop.layout import Constants
from pyautonomousagent.loop.source import alias
from pyautonomousagent.missions import gathering
from pyautonomousagent.models import drone2d

NEAR, SENDER, EACH = DeviceMessages.NEAR, DeviceMessages.SENDER, DeviceMessages.EACH

needs_numba = pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")


def _message_source(scenario: str) -> str:
    sim = Simulation.create(
        load(scenario).with_overrides(agents=4, iterations=10), seed=1, engine="compiled"
    )
    engine = sim.engine
    fused = engine._fusable(sim)
    assert fused is not None and fused.messaging is not None
    layout = engine.layout.__class__(
        **{**vars(engine.layout), "constants": Constants(), "vertical": fused.vertical}
    )
    thread = Thread(engine.program, engine.kernels, layout, fused.sensors, engine.stages)
    return message_module_source(thread, fused.messaging)


@needs_numba
@pytest.mark.parametrize("scenario", ["gathering", "gathering-3d"])
def test_the_message_kernels_are_generated_python_without_libm(scenario: str) -> None:
    source = _message_source(scenario)
    tree = ast.parse(source)  # valid Python
    names = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
    per_type = {"handle_all_", "handle_each_", "handle_near_", "flag_", "scatter_"}
    assert {"sense_move", "tick"} <= names
    kinds = {re.sub(r"\d+$", "", name) for name in names}
    assert kinds == {"sense_move", "tick", "handle_sender_", *per_type}
    assert all(f"{kind}{k}" in names for kind in per_type for k in (0, 1))  # two types
    assert "handle_sender_0" in names and "handle_sender_1" not in names  # shared data's
    assert f"{alias(drone2d.step_agent)}(" in source  # its sin/cos: kernels.sincos_degrees
    assert not re.search(r"math\.(sin|cos|tan|atan2?|hypot|exp|log)\b", source)
    assert "prange" not in source and "np." not in source.split("import", 4)[-1]


#: Run under NUMBA_ENABLE_CUDASIM=1: gathering on the GPU engine in the simulator against the
#: batched engine, 3 seeds; raises at the first difference, else prints what was sent and "same".
SIMULATED = textwrap.dedent(
    """
    import sys
    from collections import Counter
    from pyautonomousagent import Simulation, load
    from pyautonomousagent.engines import gpu_messages
    from pyautonomousagent.testing import check_same_runs

    scenario_name, reach, every, room = sys.argv[1], float(sys.argv[2]), *map(int, sys.argv[3:5])
    gpu_messages.DeviceMessages.ROOM = room
    handled = Counter()  # (type, how) -> deliveries handled so on the device
    handle = gpu_messages.DeviceMessages._handle
    def counted(self, k, how, *rest):
        handled[self.messaging.types[k].replace(" ", "_"), how] += 1
        return handle(self, k, how, *rest)
    gpu_messages.DeviceMessages._handle = counted

    def differ(a, b):
        check_same_runs(a, b, ("batched", "gpu"))  # raises at the first difference
        sa, sb = a.mission.shared, b.mission.shared
        if any(sa[r] != sb[r] for r in range(len(sa))):
            return "shared data"
        return ""

    for seed in (1, 2, 3):
        scenario = load(scenario_name).with_overrides(
            agents=6, iterations=40, gathering_iteration=17, datalink_range=reach)
        a, b = (Simulation.create(scenario, seed=seed, engine=e, record_every=every).run(
            progress=False) for e in ("batched", "gpu"))
        assert b.engine.name == "gpu" and b.engine.timings["kernel"] > 0.0
        found = differ(a, b)
        if found:
            print("differ", seed, found)
            sys.exit(1)
        # three iterations on the CPU mid-run (the compiled engine's tick, Python handlers)
        c = Simulation.create(scenario, seed=seed, engine="gpu", record_every=every)
        fusable = c.engine._fusable
        c.engine._fusable = lambda sim: None if 23 <= sim.world.iteration < 26 else fusable(sim)
        c.run(progress=False)
        found = differ(a, c)
        if found:
            print("differ", seed, "after stepping:", found)
            sys.exit(1)
        shared = a.mission.shared
        pairs, everyone = shared._pair_keys.size, int((shared._everyone_iteration > 0).sum())
        orders = sum(1 for e in a.events if e["event"] == "message")
        print("sent", seed, orders, everyone, pairs)
    for (name, how), times in sorted(handled.items()):
        print("handled", name, how, times)
    print("same")
    """
)


def _handled(lines: list[str]) -> dict[tuple[str, int], int]:
    """(message type, how) -> deliveries handled so on the device, from the ``handled``
    lines (``how``: ``DeviceMessages.ALL``, ``NEAR``, ``SENDER`` or ``EACH``)."""
    rows = [line.split() for line in lines if line.startswith("handled")]
    return {(name, int(how)): int(times) for _, name, how, times in rows}


def _simulate(*arguments: str) -> list[str]:
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    done = subprocess.run(
        [sys.executable, "-c", SIMULATED, *arguments],
        env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    lines = done.stdout.strip().splitlines()
    assert lines[-1] == "same", done.stdout
    return lines


@needs_numba
@pytest.mark.parametrize(("scenario", "every"), [("gathering", 1), ("gathering-3d", 3)])
def test_messages_reaching_everyone_give_the_batched_engines_bits(
    scenario: str, every: int
) -> None:
    """6 drones x 40 iterations, 3 seeds, the default range (1000 units: everyone hears
    everyone): sharing data every iteration, the gathering order at iteration 17."""
    lines = _simulate(scenario, "1000", str(every), "8")
    sent = [line.split() for line in lines if line.startswith("sent")]
    assert len(sent) == 3
    for _, _, orders, everyone, pairs in sent:
        assert int(orders) == 1  # the gathering order, a message event
        assert int(everyone) == 6 and int(pairs) == 0  # every drone's data heard by all
    # to everyone, in parallel: the shared data by sender, the gathering order per receiver
    handled = _handled(lines)
    assert set(handled) == {("sharing_data", SENDER), ("gathering", EACH)}, handled
    assert handled["sharing_data", SENDER] > 3 * 30  # nearly every iteration


@needs_numba
@pytest.mark.parametrize(
    ("scenario", "every", "room"),
    [("gathering", 1, 8), ("gathering", 3, 1), ("gathering-3d", 1, 2)],
)
def test_messages_reaching_only_some_are_delivered_on_the_device(
    scenario: str, every: int, room: int
) -> None:
    """The same runs with a 25-unit range: each drone hears only its neighbours, each
    receiver takes the messages in range on the device (``handle_near``); ``room`` 1 or 2
    makes the shared-data table grow while the messages are handled."""
    lines = _simulate(scenario, "25", str(every), str(room))
    sent = [line.split() for line in lines if line.startswith("sent")]
    assert len(sent) == 3
    for _, _, orders, everyone, pairs in sent:
        assert int(orders) == 1
        assert int(everyone) == 0 and 6 <= int(pairs) < 30  # some pairs heard, not all
    handled = _handled(lines)
    assert handled.get(("sharing_data", NEAR), 0) > 3 * 30  # near, most iterations


#: Run under NUMBA_ENABLE_CUDASIM=1: radiation-search (random wander, the recorded ``found``
#: message) on the GPU engine against the batched engine, 3 seeds; raises at the first
#: difference, else prints the iterations of the ``found`` messages of each seed and "same".
RADIATION = textwrap.dedent(
    """
    import sys
    import warnings
    from collections import Counter
    import numpy as np
    from pyautonomousagent import Simulation, load
    from pyautonomousagent.engines import gpu_messages
    from pyautonomousagent.testing import check_same_runs

    warnings.simplefilter("ignore", RuntimeWarning)  # the generator's uint64 wraps in Python
    reach = float(sys.argv[1])
    handled = Counter()  # (type, how) -> deliveries handled so on the device
    handle = gpu_messages.DeviceMessages._handle
    def counted(self, k, how, *rest):
        handled[self.messaging.types[k].replace(" ", "_"), how] += 1
        return handle(self, k, how, *rest)
    gpu_messages.DeviceMessages._handle = counted
    for seed in (0, 1, 2):
        scenario = load("radiation-search").with_overrides(
            agents=6, iterations=300, datalink_range=reach)
        a, b = (Simulation.create(scenario, seed=seed, engine=e).run(progress=False)
                for e in ("batched", "gpu"))
        assert b.engine.name == "gpu" and b.engine.timings["kernel"] > 0.0
        check_same_runs(a, b, ("batched", "gpu"))
        found = [e["iteration"] for e in a.events if e.get("type") == "found"]
        print("found", seed, *found)
    for (name, how), times in sorted(handled.items()):
        print("handled", name, how, times)
    print("same")
    """
)


@needs_numba
@pytest.mark.parametrize("reach", ["1000", "15"])
def test_radiation_search_gives_the_batched_engines_bits(reach: str) -> None:
    """6 drones x 300 iterations, 3 seeds (different wanders): a drone finds the source and
    sends ``found``, heard by everyone (range 1000) or by its neighbours only (range 15:
    delivered on the device per receiver, ``Receive``)."""
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    done = subprocess.run(
        [sys.executable, "-c", RADIATION, reach], env=env, capture_output=True, text=True,
        timeout=600,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    lines = done.stdout.strip().splitlines()
    assert lines[-1] == "same", done.stdout
    found = [line.split()[2:] for line in lines if line.startswith("found")]
    assert len(found) == 3 and all(found), lines  # every seed sent found at least once
    assert len({tuple(f) for f in found}) > 1  # the seeds wander differently
    handled = _handled(lines)
    assert set(handled) == ({("found", EACH)} if reach == "1000" else {("found", NEAR)}), handled


#: Run under NUMBA_ENABLE_CUDASIM=1 with a scenario folder: gathering with a tree that sends
#: "sharing data" twice per tick (before and after a refuel to 100 %, so the two differ in
#: energy), on the GPU engine against the batched engine; prints the shared data's energies
#: heard, how each delivery was handled (type, how, messages) and "same".
TWICE = textwrap.dedent(
    """
    import sys
    from collections import Counter
    from pathlib import Path
    from pyautonomousagent import Simulation, load
    from pyautonomousagent.engines import gpu_messages
    from pyautonomousagent.testing import check_same_runs

    handled = Counter()
    handle = gpu_messages.DeviceMessages._handle
    def counted(self, k, how, m, *rest):
        handled[self.messaging.types[k].replace(" ", "_"), how, m] += 1
        return handle(self, k, how, m, *rest)
    gpu_messages.DeviceMessages._handle = counted
    scenario = load(Path(sys.argv[1]) / "twice.yaml").with_overrides(
        agents=5, iterations=30, gathering_iteration=12)
    for seed in (1, 2):
        a, b = (Simulation.create(scenario, seed=seed, engine=e).run(progress=False)
                for e in ("batched", "gpu"))
        assert b.engine.name == "gpu"
        check_same_runs(a, b, ("batched", "gpu"))
        sa, sb = a.mission.shared, b.mission.shared
        if any(sa[r] != sb[r] for r in range(len(sa))):
            print("differ", seed, "shared data")
            sys.exit(1)
        print("energy", *sorted({h["energy"] for r in range(len(sa)) for h in sa[r].values()}))
    for (name, how, m), times in sorted(handled.items()):
        print("handled", name, how, m, times)
    print("same")
    """
)


@needs_numba
def test_a_sender_sending_a_type_twice_in_a_tick_keeps_its_messages_order(
    tmp_path: Path,
) -> None:
    """A tree may send one type from two nodes: the inbox holds each sender's two messages
    side by side (canonical order), and the shared data handled by sender keeps the later
    one, the batched engine's (5 drones x 30 iterations, 2 seeds)."""
    folder = Path(gathering.__file__).parent
    tree = (folder / "gathering.xml").read_text()
    one = '<Action_Transmit_Shared_Data_S name="action_transmit_shared_data_s"/>'
    twice = (
        '<Action_Transmit_Shared_Data_S name="first"/>'
        '<Action_Refuel_A name="top_up" rate="100"/>'
        '<Action_Transmit_Shared_Data_S name="second"/>'
    )
    assert one in tree
    (tmp_path / "twice.xml").write_text(tree.replace(one, twice))
    yaml = (folder / "gathering.yaml").read_text()
    (tmp_path / "twice.yaml").write_text(yaml.replace("tree: gathering.xml", "tree: twice.xml"))
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    done = subprocess.run(
        [sys.executable, "-c", TWICE, str(tmp_path)], env=env, capture_output=True, text=True,
        timeout=600,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    lines = done.stdout.strip().splitlines()
    assert lines[-1] == "same", done.stdout
    energies = [line.split()[1:] for line in lines if line.startswith("energy")]
    assert energies == [["100.0"], ["100.0"]]  # the second message of each sender, topped up
    handled = {tuple(line.split()[1:4]): int(line.split()[4]) for line in lines
               if line.startswith("handled")}  # fmt: skip
    assert handled[("sharing_data", str(SENDER), "10")] == 2 * 29  # 5 drones, 2 messages each
