# Reference solution of lesson 09 (injected in place of the exercise cell by the tests).
# Without a mouse: the fields typed as the page sends them, then what Save XML calls.
# ruff: noqa: F821  (studio and fig6 come from the lesson's earlier cells)
import copy


def typed(block, kind, **ports):
    """``block`` with ``ports`` typed into every block of type ``kind`` inside it."""
    if block["type"] == kind:
        block["ports"].update(ports)
    for child in block["children"]:
        typed(child, kind, **ports)
    return block


early = typed(typed(copy.deepcopy(fig6), "Condition_Low_Energy_Level", threshold="60"),
              "Action_Refuel_A", rate="5")  # fmt: skip
print("the tree check:", studio.set_tree({"tree": early}))
tree_file = studio.session.save_tree("refuel-early", "xml").name
