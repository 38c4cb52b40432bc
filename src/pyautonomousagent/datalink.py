"""The datalink: typed messages with a range, delivered at the end of the iteration (Phase 5).

A message has a sender, receivers (everyone, or a list of agent indices), a type, data
and the sender's position when it was sent. Messages sent during an iteration wait in the
channel; :meth:`Datalink.deliver` hands each to every receiver within range of the
sender's position (never to the sender) and clears the channel. Receivers act on them in
Phase 2 of the next iteration: the mission's handler of each message type
(:func:`pyautonomousagent.simulation.phases.process_messages`).

One call of :meth:`Datalink.send` may carry the messages of many senders at once (the
batched engine) or one (:class:`OneMessage`). Delivery puts the messages of a type in a
canonical order (by sender, then sending order), so every engine delivers the same
messages in the same order.

Cost: when every agent lies within range of every other (the usual case of a long-range
link), a broadcast is recorded once, not once per receiver (O(N) time and memory). Otherwise
receivers are found on a uniform grid of cells one range wide
(:mod:`pyautonomousagent.proximity`), in time proportional to the pairs in range, not N^2.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple, cast

import numpy as np

from pyautonomousagent.arrays import hypot
from pyautonomousagent.proximity import CellList


@dataclass
class Messages:
    """Messages of one type, one row each.

    Attributes:
        type: message type, a name the mission declares (e.g. ``"gathering"``).
        senders: sending agents, shape (M,).
        order: per-sender sending order (a global counter), shape (M,).
        x, y: sender positions when sent, shape (M,).
        data: payload arrays, name -> shape (M,).
        lists: per message, the row of ``receiver_lists`` naming its receivers, or -1 for
            everyone; shape (M,).
        receiver_lists: the receiver lists (int arrays) of targeted messages.
    """

    type: str
    senders: np.ndarray
    order: np.ndarray
    x: np.ndarray
    y: np.ndarray
    data: dict[str, np.ndarray]
    lists: np.ndarray
    receiver_lists: list[np.ndarray]

    def __len__(self) -> int:
        return int(self.senders.size)

    def receivers(self, row: int) -> np.ndarray | None:
        """The intended receivers of message ``row``, or None for everyone."""
        which = int(self.lists[row])
        return None if which < 0 else self.receiver_lists[which]

    def take(self, rows: np.ndarray) -> Messages:
        """The messages at ``rows``, in that order."""
        return Messages(
            self.type,
            self.senders[rows],
            self.order[rows],
            self.x[rows],
            self.y[rows],
            {k: v[rows] for k, v in self.data.items()},
            self.lists[rows],
            self.receiver_lists,
        )


@dataclass
class Delivery:
    """The messages of one type, as delivered.

    Attributes:
        messages: the messages, in canonical order (by sender, then sending order).
        receivers, rows: delivered pairs (receiver index, message row), in message order;
            empty when ``to_all`` holds.
        to_all: every message was a broadcast and every agent was in range of every
            sender: each message reached every agent but its sender (pairs not listed).
    """

    messages: Messages
    receivers: np.ndarray
    rows: np.ndarray
    to_all: bool = False

    def pairs(self, n_agents: int) -> tuple[np.ndarray, np.ndarray]:
        """(receivers, rows) of every delivery, listing them also when ``to_all`` holds."""
        if not self.to_all:
            return self.receivers, self.rows
        m = len(self.messages)
        receivers = np.tile(np.arange(n_agents), m)
        rows = np.repeat(np.arange(m), n_agents)
        keep = receivers != self.messages.senders[rows]
        return receivers[keep], rows[keep]


class OneMessage(NamedTuple):
    """A broadcast by one agent, kept as plain Python numbers until delivery (the py_trees
    engine sends one message per tick: packing it into arrays then would cost more than
    the message). :meth:`Datalink.deliver` packs runs of them into :class:`Messages`.

    Attributes:
        type: message type; sender: agent index; order: the global sending counter;
        x, y: the sender's position; data: payload name -> number.
    """

    type: str
    sender: int
    order: int
    x: float
    y: float
    data: dict[str, float]


@dataclass
class Datalink:
    """The broadcast channel shared by the swarm.

    Attributes:
        range: largest sender-receiver distance that a message crosses (world units).
        channel: messages sent this iteration, not yet delivered (one entry per send call,
            each run of one-agent broadcasts packed into one entry).
    """

    range: float
    _queue: list[Messages | OneMessage] = field(default_factory=list)
    _sent: int = 0

    @property
    def channel(self) -> list[Messages]:
        """Messages sent this iteration, not yet delivered (a packed copy of the queue)."""
        return _packed(self._queue)

    def send(
        self,
        sender: Any,
        type: str,
        data: Mapping[str, Any],
        sender_position: tuple[Any, Any],
        receivers: Sequence[int] | None = None,
    ) -> None:
        """Put messages on the channel; they are delivered at the end of the iteration.

        Args:
            sender: one agent index, or an array of them (one message each).
            type: the message type.
            data: payload: name -> a number, or an array with one entry per sender.
            sender_position: (x, y) of the sender(s), numbers or arrays.
            receivers: intended receivers (agent indices), or None for everyone.
        """
        if receivers is None and isinstance(sender, int):
            one = _one_message(type, sender, self._sent, data, sender_position)
            if one is not None:
                self._queue.append(one)
                self._sent += 1
                return
        senders = np.array(sender, dtype=np.int64, ndmin=1)  # a copy: the caller's may change
        m = senders.size
        order = np.arange(self._sent, self._sent + m)
        self._sent += m
        columns = [sender_position[0], sender_position[1], *data.values()]
        if all(isinstance(c, np.ndarray) and c.shape == (m,) for c in columns):
            x, y, *rest = np.array(columns, dtype=np.float64)  # one copy for all
        else:
            x, y, *rest = (_one_each(c, m) for c in columns)
        payload = dict(zip(data, rest, strict=True))
        lists = [] if receivers is None else [np.asarray(receivers, dtype=np.int64)]
        which = np.full(m, -1 if receivers is None else 0, dtype=np.int64)
        self._queue.append(Messages(type, senders, order, x, y, payload, which, lists))

    def deliver(self, x: np.ndarray, y: np.ndarray) -> list[Delivery]:
        """Phase 5: hand every message to its receivers within range; clear the channel.

        Args:
            x, y: the receivers' current positions, shape (N,).

        Returns:
            One :class:`Delivery` per message type, in order of first sending.
        """
        deliveries = [self._deliver_type(merged, x, y) for merged in _merge_by_type(self.channel)]
        self._queue.clear()
        return deliveries

    def _deliver_type(self, messages: Messages, x: np.ndarray, y: np.ndarray) -> Delivery:
        broadcast = messages.lists < 0
        if _all_true(broadcast) and self._all_in_range(messages, x, y):
            empty = np.zeros(0, dtype=np.int64)
            return Delivery(messages, empty, empty, to_all=True)
        parts = [grid_pairs(messages.x, messages.y, np.flatnonzero(broadcast), x, y, self.range)]
        for row in np.flatnonzero(~broadcast):
            targets = messages.receiver_lists[messages.lists[row]]
            near = hypot(x[targets] - messages.x[row], y[targets] - messages.y[row]) <= self.range
            parts.append((targets[near], np.full(int(near.sum()), row, dtype=np.int64)))
        receivers, rows = (np.concatenate(found) for found in zip(*parts, strict=True))
        keep = receivers != messages.senders[rows]
        order = np.lexsort((receivers[keep], rows[keep]))
        return Delivery(messages, receivers[keep][order], rows[keep][order])

    def _all_in_range(self, messages: Messages, x: np.ndarray, y: np.ndarray) -> bool:
        """True if every sender position is within range of every agent (bounding-box test)."""
        if x.size + messages.x.size <= FEW:  # a few: extents in Python, then the same hypot
            xs, ys = x.tolist() + messages.x.tolist(), y.tolist() + messages.y.tolist()
            total = sum(xs) + sum(ys)
            if total == total:  # no NaN (NumPy's max and min propagate it, Python's not)
                extent_x, extent_y = max(xs) - min(xs), max(ys) - min(ys)
                return bool(hypot(extent_x, extent_y) <= self.range)
        points = np.concatenate((x, messages.x, y, messages.y)).reshape(2, -1)  # xs; ys
        extent = points.max(axis=1) - points.min(axis=1)
        return bool(hypot(extent[0], extent[1]) <= self.range)


#: Up to this many agents and messages, delivery checks them in Python: cheaper than NumPy's
#: cost per call (about a microsecond) for a few values.
FEW = 32


def _all_true(flags: np.ndarray) -> bool:
    """``flags.all()`` for a boolean array of shape (M,) (in Python for a few)."""
    if flags.size <= FEW:
        return all(flags.tolist())
    return bool(flags.all())


def _one_each(value: Any, m: int) -> np.ndarray:
    """``value`` (a number, or one per message) as a new float array of shape (m,)."""
    values = np.array(value, dtype=np.float64)  # a copy: the sender's arrays may change
    return values if values.shape == (m,) else np.broadcast_to(values, (m,)).copy()


_NUMBER = (float, int, np.number)


def _one_message(
    kind: str, sender: int, order: int, data: Mapping[str, Any], position: tuple[Any, Any]
) -> OneMessage | None:
    """One agent's broadcast as plain numbers; None if a value is no number (an array)."""
    x, y = position
    if not (isinstance(x, _NUMBER) and isinstance(y, _NUMBER)):
        return None
    plain = dict(data)
    for key, value in plain.items():
        if type(value) is not float:  # a float (the usual case: AgentView reads) is kept
            if not isinstance(value, _NUMBER):
                return None
            plain[key] = float(value)
    return OneMessage(kind, sender, order, float(x), float(y), plain)


def _packed(channel: list[Messages | OneMessage]) -> list[Messages]:
    """The channel with each run of one-agent messages of the same type and payload names
    packed into one :class:`Messages` (same rows, same order)."""
    packed: list[Messages] = []
    for _, group in itertools.groupby(channel, _run_key):
        run = list(group)
        first = run[0]
        packed.append(first if isinstance(first, Messages) else _pack(cast(list[OneMessage], run)))
    return packed


def _run_key(entry: Messages | OneMessage) -> object:
    """What the one-agent messages of a run share (their type and payload names); a
    :class:`Messages` entry is a run of its own."""
    return (entry.type, entry.data.keys()) if isinstance(entry, OneMessage) else id(entry)


def _pack(run: list[OneMessage]) -> Messages:
    """One-agent messages of one type (and payload names) as one :class:`Messages`."""
    ids = np.array([(r.sender, r.order, -1) for r in run], dtype=np.int64).T
    names = tuple(run[0].data)
    if all(tuple(r.data) == names for r in run):  # the usual case: the same order of names
        rows = [(r.x, r.y, *r.data.values()) for r in run]
    else:
        rows = [(r.x, r.y, *(r.data[k] for k in names)) for r in run]
    values = np.array(rows, dtype=np.float64).T
    data = dict(zip(names, values[2:], strict=True))
    return Messages(run[0].type, ids[0], ids[1], values[0], values[1], data, ids[2], [])


def _merge_by_type(channel: list[Messages]) -> list[Messages]:
    """The channel's messages grouped by type, each group in canonical order."""
    types = list(dict.fromkeys(m.type for m in channel))
    merged = []
    for kind in types:
        parts = [m for m in channel if m.type == kind]
        if len(parts) == 1:  # nothing to merge: only the payload's names sorted, as below
            one = parts[0]
            one.data = {k: one.data[k] for k in sorted(one.data)}
            merged.append(_canonical(one))
            continue
        senders, order, x, y = (
            np.concatenate([getattr(m, name) for m in parts])
            for name in ("senders", "order", "x", "y")
        )
        keys = sorted(set().union(*(m.data for m in parts)))
        data = {
            k: np.concatenate([m.data.get(k, np.full(len(m), np.nan)) for m in parts]) for k in keys
        }
        offsets = np.cumsum([0] + [len(m.receiver_lists) for m in parts])
        lists = [
            np.where(m.lists < 0, -1, m.lists + o) for m, o in zip(parts, offsets[:-1], strict=True)
        ]
        receivers = [r for m in parts for r in m.receiver_lists]
        merged.append(
            _canonical(Messages(kind, senders, order, x, y, data, np.concatenate(lists), receivers))
        )
    return merged


def _canonical(messages: Messages) -> Messages:
    """``messages`` in canonical order: by sender, then sending order (unchanged if so)."""
    senders, order = messages.senders, messages.order
    if senders.size < 2:
        return messages
    if senders.size <= FEW:  # a few messages: compared in Python, cheaper than NumPy's calls
        keys = list(zip(senders.tolist(), order.tolist(), strict=True))
        if all(a < b for a, b in zip(keys, keys[1:], strict=False)):
            return messages
    else:
        later = order[1:] > order[:-1]
        step = (senders[1:] > senders[:-1]) | ((senders[1:] == senders[:-1]) & later)
        if step.all():
            return messages
    return messages.take(np.lexsort((order, senders)))


def grid_pairs(
    sx: np.ndarray, sy: np.ndarray, rows: np.ndarray, x: np.ndarray, y: np.ndarray, reach: float
) -> tuple[np.ndarray, np.ndarray]:
    """All (receiver, message row) pairs within ``reach``, found on a grid of cells ``reach``
    wide (:class:`~pyautonomousagent.proximity.CellList` of the receivers).

    Args:
        sx, sy: message (sender) positions, shape (M,).
        rows: the message rows to place, shape (R,).
        x, y: receiver positions, shape (N,).
        reach: the range (world units).

    Returns:
        (receivers, rows) of the pairs, unordered; time and memory grow with the pairs
        found in neighbouring cells, not with N * M.
    """
    if rows.size == 0:
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty
    found, receivers = CellList((x, y), reach).candidates((sx[rows], sy[rows]))
    message = rows[found]
    near = hypot(x[receivers] - sx[message], y[receivers] - sy[message]) <= reach
    return receivers[near], message[near]


def message_events(
    deliveries: list[Delivery], types: tuple[str, ...], iteration: int, names: Sequence[str]
) -> list[dict[str, Any]]:
    """Recordable events for the messages of the given types (the mission's recorded types).

    Agents are given by name (``names[i]`` is agent i); one event per message, in
    canonical order.
    """
    return [
        {
            "iteration": iteration,
            "event": "message",
            "type": m.type,
            "sender": names[int(m.senders[row])],
            "receivers": "all" if (to := m.receivers(row)) is None else [names[int(r)] for r in to],
            "data": {k: float(v[row]) for k, v in m.data.items()},
        }
        for m in (delivery.messages for delivery in deliveries)
        if m.type in types
        for row in range(len(m))
    ]
