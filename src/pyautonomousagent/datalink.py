"""The datalink: typed messages with a range, delivered at the end of the iteration (Phase 5).

A message has a sender, receivers (everyone, or a list of agent indices), a type, data
and the sender's position when it was sent. Messages sent during an iteration wait in the
channel; :meth:`Datalink.deliver` hands each to every receiver within range of the
sender's position (never to the sender) and clears the channel. Receivers act on them in
Phase 2 of the next iteration (:func:`pyautonomousagent.simulation.phases.process_messages`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

SHARING_DATA = "sharing data"
GATHERING = "gathering"


@dataclass(frozen=True)
class Message:
    """One message on the channel.

    Attributes:
        sender: index of the sending agent.
        receivers: indices of the intended receivers, or None for all agents.
        type: message type, e.g. ``"sharing data"`` or ``"gathering"``.
        data: the payload (name -> number).
        sender_position: (x, y) of the sender when it sent the message.
    """

    sender: int
    receivers: tuple[int, ...] | None
    type: str
    data: Mapping[str, float]
    sender_position: tuple[float, float]


@dataclass(frozen=True)
class Received:
    """A message as one receiver got it."""

    receiver: int
    message: Message


@dataclass
class Datalink:
    """The broadcast channel shared by the swarm.

    Attributes:
        range: largest sender-receiver distance that a message crosses (world units).
        channel: messages sent this iteration, not yet delivered.
    """

    range: float
    channel: list[Message] = field(default_factory=list)

    def send(
        self,
        sender: int,
        type: str,
        data: Mapping[str, float],
        sender_position: tuple[float, float],
        receivers: Sequence[int] | None = None,
    ) -> None:
        """Put a message on the channel; it is delivered at the end of the iteration."""
        targets = None if receivers is None else tuple(int(r) for r in receivers)
        position = (float(sender_position[0]), float(sender_position[1]))
        self.channel.append(Message(int(sender), targets, type, dict(data), position))

    def deliver(self, x: np.ndarray, y: np.ndarray) -> list[Received]:
        """Phase 5: hand every message to its receivers within range, then clear the channel.

        Args:
            x, y: the receivers' current positions, shape (N,).

        Returns:
            One entry per (receiver, message), in sending order.
        """
        delivered: list[Received] = []
        everyone = np.arange(len(x))
        for message in self.channel:
            targets = everyone if message.receivers is None else np.asarray(message.receivers, int)
            sx, sy = message.sender_position
            in_range = np.hypot(x[targets] - sx, y[targets] - sy) <= self.range
            for receiver in targets[in_range & (targets != message.sender)]:
                delivered.append(Received(int(receiver), message))
        self.channel.clear()
        return delivered


def message_events(
    messages: list[Message], types: tuple[str, ...], iteration: int, names: Sequence[str]
) -> list[dict[str, Any]]:
    """Recordable events for the messages of the given types (e.g. gathering orders).

    Agents are given by name (``names[i]`` is agent i).
    """
    return [
        {
            "iteration": iteration,
            "event": "message",
            "type": m.type,
            "sender": names[m.sender],
            "receivers": "all" if m.receivers is None else [names[r] for r in m.receivers],
            "data": dict(m.data),
        }
        for m in messages
        if m.type in types
    ]
