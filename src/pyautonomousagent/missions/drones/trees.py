"""The paper's trees of its drones, as engine-independent descriptions, registered by name
(:data:`pyautonomousagent.bt.trees.TREES`: a scenario may say ``tree: gathering``).

``gathering`` is the paper's Fig. 6 and ``patrol`` its Fig. 12; instance names follow the
paper's Table 2. (The missions' tree files, ``gathering.xml`` and ``patrol.xml``, hold the same
trees; tests/test_tree_files.py holds them equal.)
"""

from __future__ import annotations

from pyautonomousagent.bt.spec import (
    Node,
    fallback,
    inverter,
    leaf,
    reactive_fallback,
    reactive_sequence,
    sequence,
)
from pyautonomousagent.bt.trees import TREES


def go_refuel(refueled: Node, reached: str = "condition_destination_reached") -> Node:
    """The low-energy branch of both trees: fly to the slot, refuel, then ``refueled``.

    ``reached`` names its Condition_Destination_Reached node.
    """
    return sequence(
        "sequence_low_energy",
        leaf("Condition_Low_Energy_Level"),
        leaf("Action_Set_Destination_Equal_To_Refueling_S"),
        fallback(
            "fallback_refueling",
            reactive_sequence(
                "reactive_sequence_go_to_refueling",
                inverter(
                    "inverter_destination_reached", leaf("Condition_Destination_Reached", reached)
                ),
                leaf("Action_Navigate_To_Destination_A", "action_navigate_to_destination_a_1"),
            ),
            sequence("sequence_refuel", leaf("Action_Refuel_A"), refueled),
        ),
    )


def gathering_tree() -> Node:
    """Fig. 6: share data; gather on order; refuel at low energy; else fly to the destination."""
    return reactive_sequence(
        "reactive_sequence_root",
        leaf("Action_Transmit_Shared_Data_S"),
        reactive_fallback(
            "reactive_fallback_behaviours",
            sequence(
                "sequence_gathering",
                leaf("Condition_Gathering_Moment"),
                leaf("Action_Transmit_Gathering_Message_S"),
            ),
            go_refuel(leaf("Action_Set_Destination_Equal_To_Surveillance_S")),
            leaf("Action_Navigate_To_Destination_A", "action_navigate_to_destination_a_2"),
        ),
    )


def patrol_tree() -> Node:
    """Fig. 12: refuel at low energy; at a surveillance position switch to the other; else fly."""
    return reactive_fallback(
        "reactive_fallback_root",
        go_refuel(
            leaf("Action_Set_Destination_Equal_To_Current_Surveillance_S"),
            "condition_destination_reached_1",
        ),
        sequence(
            "sequence_patrol",
            leaf("Condition_Destination_Reached", "condition_destination_reached_2"),
            leaf("Action_Set_Destination_Equal_To_Other_Surveillance_S"),
        ),
        leaf("Action_Navigate_To_Destination_A", "action_navigate_to_destination_a_2"),
    )


TREES.register("gathering", gathering_tree)
TREES.register("patrol", patrol_tree)
