"""One agent's recorded node statuses as a Groot2 log: BehaviorTree.CPP's ``.btlog``
(the format its ``FileLogger2`` writes and Groot2's log replay opens; its layout, all
integers little-endian: docs/data.md).

A recorded run gives each node's status after every recorded tick; the log holds, at each
recorded iteration, the nodes whose status differs from the previous record (INVALID, "not
ticked", is BehaviorTree.CPP's IDLE). Iteration ``t`` is at ``t * usec_per_iteration``.
"""

from __future__ import annotations

import struct
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pyautonomousagent.bt.files import to_text_format
from pyautonomousagent.bt.spec import Node
from pyautonomousagent.bt.status import BTCPP_CODES, INVALID

MAGIC = b"BTCPP4-FileLogger2"
"""The file's first bytes."""
PROTOCOL = 1
"""The protocol byte after the magic."""
TRANSITION = np.dtype([("usec", "<u8"), ("uid", "<u2"), ("status", "u1")])
"""A status change: log microseconds since the start, the node's ``_uid``, its new status."""
RECORD = 9
"""Bytes per transition record."""
_KEPT = [0, 1, 2, 3, 4, 5, 8, 9, 10]  # the bytes of a TRANSITION a record holds: usec's low 6
USEC_PER_ITERATION = 100_000
"""Default log time of one iteration: 0.1 s, so Groot2 replays 10 iterations a second."""


@dataclass(frozen=True)
class BtLog:
    """A ``.btlog`` as read.

    Attributes:
        xml: the tree XML.
        start_usec: the start time, microseconds since the Unix epoch.
        transitions: structured array with fields ``usec`` (since the start), ``uid`` and
            ``status`` (BehaviorTree.CPP codes), shape (transitions,).
        protocol: the protocol byte.
    """

    xml: str
    start_usec: int
    transitions: np.ndarray
    protocol: int


def tree_xml(root: Node) -> str:
    """The tree as BehaviorTree.CPP 4 XML with ``_uid`` on every node (1, 2, ... in tick
    order) and ``_fullpath=""`` on the tree, as ``FileLogger2`` writes it."""
    document = ET.fromstring(to_text_format(root, "xml").split("?>", 1)[-1])
    trees = document.findall("BehaviorTree")
    elements = [e for e in trees[0].iter() if e is not trees[0]]
    nodes = list(root.walk())
    if len(elements) != len(nodes):
        raise ValueError(f"the tree XML has {len(elements)} nodes, the tree {len(nodes)}")
    trees[0].set("_fullpath", "")
    for uid, element in enumerate(elements, start=1):
        element.set("_uid", str(uid))
    document.attrib.pop("main_tree_to_execute", None)
    return ET.tostring(document, encoding="unicode")


def transitions(
    iterations: np.ndarray, statuses: np.ndarray, usec_per_iteration: int = USEC_PER_ITERATION
) -> np.ndarray:
    """The status changes of one agent's trace, in time then tick order.

    Args:
        iterations: recorded iterations, shape (records,).
        statuses: the agent's node statuses (our codes), shape (records, nodes).
        usec_per_iteration: log microseconds per iteration.

    Returns:
        structured array (``usec`` uint64, ``uid`` uint16, ``status`` uint8), BT.CPP codes.
    """
    codes = np.zeros(max(BTCPP_CODES) + 1, dtype=np.uint8)
    codes[list(BTCPP_CODES)] = list(BTCPP_CODES.values())
    previous = np.vstack([np.full((1, statuses.shape[1]), INVALID, statuses.dtype), statuses[:-1]])
    rows, nodes = np.nonzero(statuses != previous)  # row-major: by record, then node
    out = np.zeros(rows.size, dtype=TRANSITION)
    out["usec"] = iterations[rows].astype(np.uint64) * np.uint64(usec_per_iteration)
    out["uid"] = nodes + 1
    out["status"] = codes[statuses[rows, nodes]]
    return out


def write_btlog(
    path: str | Path,
    root: Node,
    iterations: np.ndarray,
    statuses: np.ndarray,
    usec_per_iteration: int = USEC_PER_ITERATION,
    start_usec: int | None = None,
) -> Path:
    """Write one agent's trace as a ``.btlog`` at ``path``; return the path.

    Args:
        root: the tree that was ticked.
        iterations: recorded iterations, shape (records,).
        statuses: the agent's node statuses, shape (records, nodes in ``root.walk()`` order).
        usec_per_iteration: log microseconds per iteration.
        start_usec: the header's start time; by default now.
    """
    path = Path(path)
    if path.suffix != ".btlog":
        raise ValueError(f"{path}: a Groot2 log must end in .btlog")
    xml = tree_xml(root).encode("utf-8")
    records = transitions(iterations, statuses, usec_per_iteration)
    if records.size and int(records["usec"].max()) >= 1 << 48:
        raise ValueError("the run is too long for 6-byte log times; lower usec_per_iteration")
    start = int(time.time() * 1e6) if start_usec is None else start_usec
    packed = records.view(np.uint8).reshape(-1, TRANSITION.itemsize)[:, _KEPT]
    with path.open("wb") as file:
        file.write(MAGIC + bytes([PROTOCOL]) + struct.pack("<i", len(xml)) + xml)
        file.write(struct.pack("<q", start))
        file.write(packed.tobytes())
    return path


def read_btlog(path: str | Path) -> BtLog:
    """Read a ``.btlog`` (ours or BehaviorTree.CPP's); ValueError if it is not one."""
    data = Path(path).read_bytes()
    if not data.startswith(MAGIC):
        raise ValueError(f"{path}: not a FileLogger2 .btlog (no {MAGIC.decode()} header)")
    at = len(MAGIC)
    protocol = data[at]
    (size,) = struct.unpack_from("<i", data, at + 1)
    xml_start = at + 5
    xml = data[xml_start : xml_start + size].decode("utf-8")
    (start,) = struct.unpack_from("<q", data, xml_start + size)
    body = np.frombuffer(data, dtype=np.uint8, offset=xml_start + size + 8)
    count = body.size // RECORD
    wide = np.zeros((count, TRANSITION.itemsize), dtype=np.uint8)
    wide[:, _KEPT] = body[: count * RECORD].reshape(count, RECORD)
    return BtLog(xml, start, wide.view(TRANSITION)[:, 0], protocol)
