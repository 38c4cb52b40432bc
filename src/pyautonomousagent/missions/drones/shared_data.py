"""What each drone last heard from each other drone by "sharing data" messages."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pyautonomousagent.datalink import Delivery
from pyautonomousagent.kernels import HandlerKernel, Receive
from pyautonomousagent.missions.drones.kernels import remember_everyone, remember_pair


@dataclass
class SharedData:
    """What each agent last heard from each other agent by "sharing data" messages.

    A broadcast that reached everyone is stored once per sender (O(N) memory); deliveries
    that reached only some agents are stored per (receiver, sender) pair that occurred.

    Attributes:
        fields: the payload names kept, e.g. ``("x", "y", "speed", ...)``.
    """

    n_agents: int
    fields: tuple[str, ...] = ("x", "y", "speed", "heading", "damage", "energy")
    _everyone_iteration: np.ndarray = field(init=False)
    _everyone_data: np.ndarray = field(init=False)
    _pair_keys: np.ndarray = field(init=False)
    _pair_iteration: np.ndarray = field(init=False)
    _pair_data: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        n, f = self.n_agents, len(self.fields)
        # iteration + 1 of the latest broadcast heard from each sender, 0: none; zeros, so
        # that a swarm that never broadcasts keeps no memory for it (pages never touched)
        self._everyone_iteration = np.zeros(n, dtype=np.int64)
        self._everyone_data = np.zeros((n, f))
        self._pair_keys = np.zeros(0, dtype=np.int64)
        self._pair_iteration = np.zeros(0, dtype=np.int64)
        self._pair_data = np.zeros((0, f))

    def store(self, delivery: Delivery, iteration: int) -> None:
        """Remember the latest message per sender (and per receiver) of ``delivery``."""
        messages = delivery.messages
        values = np.array([messages.data[k] for k in self.fields]).T  # (M, fields)
        if delivery.to_all:
            senders = messages.senders
            if not _distinct_ascending(senders):  # keep each sender's last message only
                last = _last_per_key(senders)
                senders, values = senders[last], values[last]
            self._everyone_iteration[senders] = iteration + 1
            self._everyone_data[senders] = values
            return
        keys = delivery.receivers * self.n_agents + messages.senders[delivery.rows]
        last = _last_per_key(keys)
        self._merge_pairs(keys[last], iteration, values[delivery.rows[last]])

    def _merge_pairs(self, keys: np.ndarray, iteration: int, values: np.ndarray) -> None:
        order = np.argsort(keys)
        keys, values = keys[order], values[order]
        at = np.searchsorted(self._pair_keys, keys)
        known = at < self._pair_keys.size
        known[known] = self._pair_keys[at[known]] == keys[known]
        self._pair_iteration[at[known]] = iteration
        self._pair_data[at[known]] = values[known]
        new = ~known
        self._pair_keys = np.insert(self._pair_keys, at[new], keys[new])
        self._pair_iteration = np.insert(self._pair_iteration, at[new], iteration)
        self._pair_data = np.insert(self._pair_data, at[new], values[new], axis=0)

    def kernel(self) -> HandlerKernel:
        """:meth:`store` compiled: of a delivery that reached everyone (it writes the same
        per-sender arrays, only the sender's rows: ``by_sender``), and per receiver
        (``kernels.remember_pair`` on the arrays of :meth:`pair_table`, taken back by
        :meth:`keep_pair_table`)."""
        state = (self._everyone_iteration, self._everyone_data)
        receive = Receive(remember_pair, self.pair_table, self.keep_pair_table)
        return HandlerKernel(
            remember_everyone, self.fields, state=state, receive=receive, by_sender=True
        )

    def pair_table(self, room: int) -> tuple[np.ndarray, ...]:
        """The pairs heard as one row per receiver (``kernels.remember_pair``'s arrays):
        ``full`` (1,) int64 zero, ``senders`` (N, R) int64 (-1: free slot), ``iterations``
        (N, R) int64 and ``data`` (N, R, fields), R the larger of ``room`` and the most
        senders one receiver has heard; each row's pairs first, by sender."""
        n = self.n_agents
        receivers = self._pair_keys // n
        first = np.searchsorted(receivers, receivers)  # keys ascending: rows grouped
        slot = np.arange(receivers.size) - first
        room = max(room, int(slot.max()) + 1 if slot.size else 0)
        senders = np.full((n, room), -1, dtype=np.int64)
        iterations = np.zeros((n, room), dtype=np.int64)
        data = np.zeros((n, room, len(self.fields)))
        senders[receivers, slot] = self._pair_keys % n
        iterations[receivers, slot] = self._pair_iteration
        data[receivers, slot] = self._pair_data
        return np.zeros(1, dtype=np.int64), senders, iterations, data

    def keep_pair_table(self, table: tuple[np.ndarray, ...]) -> None:
        """Take back the pairs of a :meth:`pair_table` (written by ``remember_pair``)."""
        _, senders, iterations, data = table
        receivers, slot = np.nonzero(senders >= 0)
        keys = receivers * self.n_agents + senders[receivers, slot]
        order = np.argsort(keys)
        self._pair_keys = keys[order]
        self._pair_iteration = iterations[receivers, slot][order]
        self._pair_data = data[receivers, slot][order]

    def __len__(self) -> int:
        return self.n_agents

    def __iter__(self) -> Iterator[dict[int, dict[str, float]]]:
        return (self[r] for r in range(self.n_agents))

    def __getitem__(self, receiver: int) -> dict[int, dict[str, float]]:
        """Sender -> latest data (with its ``iteration``) as heard by ``receiver``."""
        if not 0 <= receiver < self.n_agents:
            raise IndexError(f"no agent {receiver}; there are {self.n_agents}")
        heard: dict[int, dict[str, float]] = {}
        for sender in np.flatnonzero(self._everyone_iteration > 0).tolist():
            if sender != receiver:
                heard[sender] = self._row(
                    self._everyone_data[sender], self._everyone_iteration[sender] - 1
                )
        lo, hi = np.searchsorted(
            self._pair_keys, [receiver * self.n_agents, (receiver + 1) * self.n_agents]
        )
        for k in range(lo, hi):
            sender = int(self._pair_keys[k] % self.n_agents)
            if sender not in heard or heard[sender]["iteration"] < self._pair_iteration[k]:
                heard[sender] = self._row(self._pair_data[k], self._pair_iteration[k])
        return heard

    def _row(self, values: np.ndarray, iteration: Any) -> dict[str, float]:
        return {**dict(zip(self.fields, values.tolist(), strict=True)), "iteration": int(iteration)}


def _last_per_key(keys: np.ndarray) -> np.ndarray:
    """Positions of the last occurrence of each distinct key (ascending by key)."""
    if _distinct_ascending(keys):
        return np.arange(keys.size)
    reversed_first = np.unique(keys[::-1], return_index=True)[1]
    return keys.size - 1 - reversed_first


def _distinct_ascending(keys: np.ndarray) -> bool:
    """Whether ``keys`` (shape (M,)) are distinct and ascending: each is its own last."""
    if keys.size <= 32:  # a few: compared in Python, cheaper than NumPy's calls
        listed = keys.tolist()
        return all(a < b for a, b in zip(listed, listed[1:], strict=False))
    return bool((keys[1:] > keys[:-1]).all())
