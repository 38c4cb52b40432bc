"""How long py_trees itself takes to tick the patrol tree (Fig. 12), with leaves that do nothing.

This is the floor under the py_trees engine: `python scripts/pytrees_floor.py` prints the
microseconds per tick of 100 such trees ticked 1000 times, with the installed py_trees.
"""

import time
from importlib import metadata

import py_trees
from py_trees.common import Status
from py_trees.composites import Selector, Sequence
from py_trees.decorators import Inverter


class Fixed(py_trees.behaviour.Behaviour):
    """A leaf that always returns the same status."""

    def __init__(self, name: str, status: Status) -> None:
        super().__init__(name)
        self.fixed = status

    def update(self) -> Status:
        return self.fixed


def patrol_shaped_tree() -> py_trees.behaviour.Behaviour:
    """The patrol tree's shape, with the statuses of a drone flying to a surveillance point."""
    go_refuel = Sequence(
        "go_refuel",
        False,
        [
            Inverter("inverter", Fixed("reached_1", Status.FAILURE)),
            Fixed("navigate_1", Status.RUNNING),
        ],
    )
    refuel = Sequence(
        "refuel", True, [Fixed("refuel", Status.RUNNING), Fixed("set_current", Status.SUCCESS)]
    )
    low_energy = Sequence(
        "low_energy",
        True,
        [
            Fixed("low_energy", Status.FAILURE),
            Fixed("set_refuel", Status.SUCCESS),
            Selector("refuelling", True, [go_refuel, refuel]),
        ],
    )
    patrol = Sequence(
        "patrol", True, [Fixed("reached_2", Status.FAILURE), Fixed("set_other", Status.SUCCESS)]
    )
    return Selector("root", False, [low_energy, patrol, Fixed("navigate_2", Status.RUNNING)])


if __name__ == "__main__":
    trees = [patrol_shaped_tree() for _ in range(100)]
    start = time.perf_counter()
    for _ in range(1000):
        for tree in trees:
            tree.tick_once()
    seconds = time.perf_counter() - start
    version = metadata.version("py_trees")
    print(f"py_trees {version}: {seconds / 100_000 * 1e6:.1f} us per tick of the patrol tree")
