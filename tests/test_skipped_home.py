"""Where SKIPPED lives (issue 26: a status "added by the record plus tests and docs, touching
at most two source files"): its code in bt/status.py, everything else about it in bt/nodes.py;
the py_trees engine maps statuses from ``status.NAMES``, so it names none of them.
"""

from __future__ import annotations

import ast
from pathlib import Path

from py_trees.common import Status

from pyautonomousagent.bt import nodes, status
from pyautonomousagent.bt.spec import Node, decorator, leaf, sequence
from pyautonomousagent.engines.btcpp import FROM_PYTREES, TO_PYTREES

PACKAGE = Path(__file__).parents[1] / "src" / "pyautonomousagent"
HOMES = {Path("bt/status.py"), Path("bt/nodes.py")}


def uses(tree: ast.AST, name: str) -> list[int]:
    """Lines where code names ``name``: a variable, an attribute or an imported name (not
    text in docstrings, comments or other strings)."""
    lines = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Name):
            found = node.id == name
        elif isinstance(node, ast.Attribute):
            found = node.attr == name
        elif isinstance(node, ast.alias):
            found = name in (node.name, node.asname)
        else:
            continue
        if found:
            lines.append(node.lineno)
    return lines


def test_uses_finds_names_not_text():
    tree = ast.parse('"""SKIPPED"""\nfrom a import SKIPPED as S\nx = codes.SKIPPED  # SKIPPED\n')
    assert uses(tree, "SKIPPED") == [2, 3]


def test_skipped_is_named_only_in_its_two_homes():
    where = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        lines = uses(ast.parse(path.read_text(encoding="utf-8")), "SKIPPED")
        if lines:
            where[path.relative_to(PACKAGE)] = lines
    assert set(where) >= HOMES, "the walk must see the two homes"
    assert set(where) == HOMES, {str(p): lines for p, lines in where.items() if p not in HOMES}


def test_every_status_maps_to_a_distinct_pytrees_status_and_back():
    assert set(TO_PYTREES) == set(status.NAMES)
    assert len(set(TO_PYTREES.values())) == len(status.NAMES)
    for code, name in status.NAMES.items():
        assert TO_PYTREES[code].name == name
        assert FROM_PYTREES[TO_PYTREES[code]] == code
    # py_trees' own statuses stay py_trees' (its composites compare against them).
    assert all(TO_PYTREES[code] is Status[name] for code, name in status.NAMES.items()
               if name in Status.__members__)  # fmt: skip
    assert TO_PYTREES[status.SKIPPED] not in set(Status)


def test_skip_problem_reads_any_node_with_the_attributes():
    once = decorator("RunOnce", "once", leaf("Action_Idle", "idle"))
    assert nodes.may_skip(once) and not nodes.may_skip(leaf("Action_Idle"))
    assert nodes.skip_problem(sequence("fine", once)) is None
    wrong = Node("Parallel", "both", (once, leaf("Action_Idle", "b")), {})
    problem = nodes.skip_problem(wrong)
    assert problem is not None and problem.startswith("Parallel 'both' cannot take child 'once'")
    assert "_skipIf, _while, RunOnce" in problem
