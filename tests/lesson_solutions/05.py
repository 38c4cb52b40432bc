# Reference solution of lesson 05 (injected in place of the exercise cell by the tests).
# ruff: noqa: F821  (Path comes from the lesson's earlier cells)
text = Path("gathering.yaml").read_text()
slow = text.replace(
    "name: action_navigate_to_destination_a_2\n",
    "name: action_navigate_to_destination_a_2\n            speed: 0.05\n",
)
Path("slow.yaml").write_text(slow)
tree_file = "slow.yaml"
