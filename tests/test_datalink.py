"""The datalink: range, receivers, the sender, clearing; and messages through the simulation."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from pyautonomousagent import Simulation, load
from pyautonomousagent.datalink import Datalink, message_events
from pyautonomousagent.missions.drones.leaves import GATHERING, SHARING_DATA
from pyautonomousagent.simulation import phases

from .conftest import on_channel


def delivered(deliveries, n: int) -> list[tuple[int, int, str]]:
    """(receiver, sender, type) of every delivery, in the order the datalink gives them."""
    out = []
    for delivery in deliveries:
        receivers, rows = delivery.pairs(n)
        senders = delivery.messages.senders
        for receiver, row in zip(receivers.tolist(), rows.tolist(), strict=True):
            out.append((receiver, int(senders[row]), delivery.messages.type))
    return out


def test_range_just_inside_and_just_outside():
    link = Datalink(range=10.0)
    link.send(0, "t", {}, (0.0, 0.0))
    x = np.array([0.0, 10.0, 10.000001, 6.0, 0.0, -7.0])
    y = np.array([0.0, 0.0, 0.0, 8.0, -10.0, -7.2])  # 10, 10.000001, 10 (6-8-10), 10, 10.04
    assert delivered(link.deliver(x, y), 6) == [(1, 0, "t"), (3, 0, "t"), (4, 0, "t")]


def test_range_just_outside_with_two_agents():
    link = Datalink(range=10.0)
    link.send(0, "t", {}, (0.0, 0.0))
    assert delivered(link.deliver(np.array([0.0, 10.000001]), np.zeros(2)), 2) == []
    link.send(0, "t", {}, (0.0, 0.0))
    assert delivered(link.deliver(np.array([0.0, 10.0]), np.zeros(2)), 2) == [(1, 0, "t")]


def test_everyone_in_range_reaches_everyone_but_the_sender():
    link = Datalink(range=1000.0)
    link.send(1, "t", {"a": 1.0}, (5.0, 5.0))
    x, y = np.array([0.0, 5.0, 9.0, 3.0]), np.array([1.0, 5.0, 2.0, 8.0])
    assert delivered(link.deliver(x, y), 4) == [(0, 1, "t"), (2, 1, "t"), (3, 1, "t")]


def test_range_uses_the_senders_position_when_it_sent():
    link = Datalink(range=5.0)
    link.send(0, "t", {}, (100.0, 100.0))
    # the sender has since moved next to agent 1; the message still starts from (100, 100)
    x, y = np.array([0.0, 1.0, 98.0]), np.array([0.0, 0.0, 100.0])
    assert delivered(link.deliver(x, y), 3) == [(2, 0, "t")]


def test_receivers_list():
    link = Datalink(range=1000.0)
    link.send(1, "t", {"a": 1.0}, (0.0, 0.0), receivers=[3, 0])
    assert on_channel(link) == [(1, "t", {"a": 1.0}, (0.0, 0.0), [3, 0])]
    x = y = np.zeros(4)
    deliveries = link.deliver(x, y)
    assert sorted(delivered(deliveries, 4)) == [(0, 1, "t"), (3, 1, "t")]
    (delivery,) = deliveries
    assert delivery.messages.receivers(0).tolist() == [3, 0]
    assert delivery.messages.data["a"].tolist() == [1.0]


def test_receivers_list_respects_range():
    link = Datalink(range=1.0)
    link.send(0, "t", {}, (0.0, 0.0), receivers=[1, 2])
    x, y = np.array([0.0, 1.0, 1.5]), np.zeros(3)
    assert delivered(link.deliver(x, y), 3) == [(1, 0, "t")]


def test_never_delivered_to_the_sender():
    link = Datalink(range=1000.0)
    link.send(2, "t", {}, (0.0, 0.0))
    link.send(1, "u", {}, (0.0, 0.0), receivers=[1, 0])  # even when it names itself
    x = y = np.zeros(3)
    assert delivered(link.deliver(x, y), 3) == [(0, 2, "t"), (1, 2, "t"), (0, 1, "u")]


def test_never_delivered_to_the_sender_out_of_range_path():
    link = Datalink(range=2.0)
    link.send(0, "t", {}, (0.0, 0.0))
    x, y = np.array([0.0, 1.0, 50.0]), np.zeros(3)
    assert delivered(link.deliver(x, y), 3) == [(1, 0, "t")]


def test_channel_cleared_after_delivery():
    link = Datalink(range=1000.0)
    link.send(0, "t", {}, (0.0, 0.0))
    assert len(on_channel(link)) == 1
    x = y = np.zeros(2)
    assert len(delivered(link.deliver(x, y), 2)) == 1
    assert link.channel == []
    assert delivered(link.deliver(x, y), 2) == []


def test_channel_cleared_even_when_nobody_is_in_range():
    link = Datalink(range=1.0)
    link.send(0, "t", {}, (0.0, 0.0))
    assert delivered(link.deliver(np.array([0.0, 50.0]), np.array([0.0, 50.0])), 2) == []
    assert link.channel == []


def test_delivery_order_is_canonical():
    # by type (first sent first), then by sender, then in each sender's sending order
    link = Datalink(range=1000.0)
    link.send(2, "first", {"k": 1.0}, (0.0, 0.0))
    link.send(0, "second", {"k": 2.0}, (0.0, 0.0))
    link.send(1, "first", {"k": 3.0}, (0.0, 0.0))
    link.send(1, "first", {"k": 4.0}, (0.0, 0.0))
    x = y = np.zeros(3)
    deliveries = link.deliver(x, y)
    assert [d.messages.type for d in deliveries] == ["first", "second"]
    assert deliveries[0].messages.senders.tolist() == [1, 1, 2]
    assert deliveries[0].messages.data["k"].tolist() == [3.0, 4.0, 1.0]
    assert delivered(deliveries, 3) == [
        (0, 1, "first"), (2, 1, "first"), (0, 1, "first"), (2, 1, "first"),
        (0, 2, "first"), (1, 2, "first"), (1, 0, "second"), (2, 0, "second"),
    ]  # fmt: skip


def test_send_many_senders_at_once():
    link = Datalink(range=1000.0)
    link.send(np.array([0, 2]), "t", {"v": np.array([1.0, 3.0])}, (np.array([0.0, 2.0]), 5.0))
    assert on_channel(link) == [
        (0, "t", {"v": 1.0}, (0.0, 5.0), None),
        (2, "t", {"v": 3.0}, (2.0, 5.0), None),
    ]


def test_send_copies_data_and_position():
    link = Datalink(range=1000.0)
    data = {"x": np.array(1.0)}
    position = np.array([2.0, 3.0])
    link.send(np.int64(0), "t", data, position)
    data["x"][...] = 9.0
    position[0] = 9.0
    assert on_channel(link) == [(0, "t", {"x": 1.0}, (2.0, 3.0), None)]


def test_message_events_lists_only_the_named_types():
    link = Datalink(range=1000.0)
    link.send(0, GATHERING, {"x": 50.0, "y": 50.0}, (0.0, 0.0))
    link.send(1, SHARING_DATA, {"x": 1.0}, (0.0, 0.0))
    link.send(1, GATHERING, {"x": 1.0, "y": 2.0}, (0.0, 0.0), receivers=[0])
    deliveries = link.deliver(np.zeros(2), np.zeros(2))
    events = message_events(deliveries, (GATHERING,), 12, ["drone1", "drone2"])
    assert events == [
        {"iteration": 12, "event": "message", "type": GATHERING, "sender": "drone1",
         "receivers": "all", "data": {"x": 50.0, "y": 50.0}},
        {"iteration": 12, "event": "message", "type": GATHERING, "sender": "drone2",
         "receivers": ["drone1"], "data": {"x": 1.0, "y": 2.0}},
    ]  # fmt: skip


# --------------------------------------------------------------------------- through the simulation


@pytest.fixture
def early_gathering() -> Simulation:
    """Gathering with drone1's order at iteration 3 (4 drones)."""
    scenario = load("gathering").with_overrides(gathering_iteration=3, iterations=10)
    return Simulation.create(scenario, seed=0)


def surveillance(sim: Simulation) -> list[tuple[float, float]]:
    bb = sim.swarm.blackboard
    return list(zip(bb["x_surveillance_position"].tolist(), bb["y_surveillance_position"].tolist(),
                    strict=True))  # fmt: skip


def test_gathering_message_acted_on_in_next_iterations_phase_2(early_gathering):
    sim = early_gathering
    original = [(50.0, 50.0), (70.0, 80.0), (40.0, 70.0), (60.0, 25.0)]
    sim.step()
    sim.step()
    assert surveillance(sim) == original
    sim.step()  # iteration 3: drone1 sends; delivered in Phase 5, not yet acted on
    assert sim.world.iteration == 3
    assert sim.events == [
        {"iteration": 3, "event": "message", "type": GATHERING, "sender": "drone1",
         "receivers": "all", "data": {"x": 50.0, "y": 50.0}},
    ]  # fmt: skip
    assert surveillance(sim) == original
    gathering = [d for d in sim.inbox if d.messages.type == GATHERING]
    assert sorted(r for d in gathering for r in d.pairs(4)[0].tolist()) == [1, 2, 3]
    # iteration 4, phase by phase: Phase 2 applies the message before the tree is ticked
    sim.world.iteration += 1
    phases.estimate_state(sim)
    assert surveillance(sim) == [(50.0, 50.0)] * 4
    assert sim.inbox == []
    phases.decide(sim)
    phases.control(sim)
    phases.deliver_messages(sim)
    phases.record(sim)
    assert [e["iteration"] for e in sim.events] == [3]  # only one gathering order
    record = sim.recorder
    np.testing.assert_array_equal(record.column("x_surveillance_position")[3], [50, 70, 40, 60])
    np.testing.assert_array_equal(record.column("x_surveillance_position")[4], [50, 50, 50, 50])
    np.testing.assert_array_equal(record.column("y_surveillance_position")[4], [50, 50, 50, 50])


def test_gathering_message_outside_range_is_lost():
    scenario = load("gathering").with_overrides(
        gathering_iteration=2, iterations=4, datalink_range=15.0
    )
    sim = Simulation.create(scenario, seed=0).run(progress=False)
    # drone1 at (20, 65): drone2 (10 away) gets it, drone3 (20 away) and drone4 (30) do not
    assert surveillance(sim) == [(50.0, 50.0), (50.0, 50.0), (40.0, 70.0), (60.0, 25.0)]
    # the order itself is recorded once, when it is sent
    assert [(e["iteration"], e["sender"]) for e in sim.events] == [(2, "drone1")]


def heard(sim: Simulation, receiver: int) -> dict[int, dict[str, float]]:
    return dict(sim.mission.shared[receiver])


def test_shared_data_keeps_the_latest_per_sender():
    sim = Simulation.create(load("gathering").with_overrides(iterations=20), seed=0)
    sim.step()
    # iteration 1's messages are acted on in iteration 2
    assert all(heard(sim, r) == {} for r in range(4))
    for _ in range(5):
        sim.step()
    t = sim.world.iteration
    for receiver in range(4):
        senders = heard(sim, receiver)
        assert sorted(senders) == sorted({0, 1, 2, 3} - {receiver})  # never from itself
        for sender, data in senders.items():
            assert data["iteration"] == t - 1
            for key in ("x", "y", "speed", "heading", "damage", "energy"):
                # sent in Phase 3 of iteration t - 1; nothing after it changes these fields
                # while the drones fly with full energy
                assert data[key] == sim.recorder.column(key)[t - 1, sender], (key, sender)
    previous = heard(sim, 1)[0]["x"]
    sim.step()
    assert heard(sim, 1)[0]["iteration"] == t
    assert heard(sim, 1)[0]["x"] == sim.recorder.column("x")[t, 0]
    assert heard(sim, 1)[0]["x"] != previous  # replaced, not appended
    assert len(heard(sim, 1)) == 3


def test_shared_data_only_from_senders_in_range():
    # slots 10 apart on a line: with range 15 each drone hears only its neighbours
    scenario = load("gathering").with_overrides(iterations=5, datalink_range=15.0)
    sim = Simulation.create(scenario, seed=0).run(progress=False)
    assert {r: sorted(heard(sim, r)) for r in range(4)} == {0: [1], 1: [0, 2], 2: [1, 3], 3: [2]}
    assert heard(sim, 2)[3]["iteration"] == 4
    assert heard(sim, 2)[3]["y"] == sim.recorder.column("y")[4, 3]


def test_shared_data_has_no_entries_for_agents_that_do_not_exist():
    sim = Simulation.create(load("gathering").with_overrides(iterations=3), seed=0).run(
        progress=False
    )
    for receiver in (4, 99):
        with pytest.raises((IndexError, KeyError)):
            sim.mission.shared[receiver]
    # iterating over it must end (at most one entry per agent), not run on forever
    assert len(list(itertools.islice(iter(sim.mission.shared), 10))) <= 4


def test_one_agent_messages_deliver_as_the_array_path_does():
    """Plain-number sends (kept as Python numbers until delivery) give the same deliveries,
    in the same canonical order, as the same messages sent as arrays."""
    x, y = np.array([0.0, 3.0, 50.0, 4.0]), np.array([0.0, 4.0, 0.0, 1.0])

    def sends(link: Datalink, plain: bool) -> list:
        one = int if plain else np.int64  # np.int64 senders take the array path
        link.send(one(3), "a", {"v": 1.5, "w": 2.0}, (1.0, 2.0))
        link.send(one(1), "a", {"w": 4.0, "v": 3.5}, (0.0, 0.0))  # other key order
        link.send(np.array([2, 0]), "b", {"v": np.array([5.0, 6.0])}, (x[[2, 0]], y[[2, 0]]))
        link.send(one(0), "a", {"v": 7.5, "w": 8.0}, (60.0, 0.0))
        link.send(one(1), "a", {"v": 9.5, "w": 1.0}, (0.0, 1.0))
        return link.deliver(x, y)

    plain, arrays = sends(Datalink(range=10.0), True), sends(Datalink(range=10.0), False)
    assert [d.messages.type for d in plain] == ["a", "b"]
    for got, want in zip(plain, arrays, strict=True):
        assert (
            got.messages.senders.tolist()
            == want.messages.senders.tolist()
            == ([0, 1, 1, 3] if got.messages.type == "a" else [0, 2])
        )
        assert {k: v.tolist() for k, v in got.messages.data.items()} == {
            k: v.tolist() for k, v in want.messages.data.items()
        }
        assert got.receivers.tolist() == want.receivers.tolist()
        assert got.rows.tolist() == want.rows.tolist()
