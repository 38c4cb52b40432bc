"""Every bad tree file gives one specific error naming the file, the line and the fix.

Each file of tests/data/bad_trees states on its first line what it must give:
``expect: LINE | part of the message | part of the fix``.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pyautonomousagent.bt.document import TreeFileError
from pyautonomousagent.bt.files import load_tree
from pyautonomousagent.cli import main

BAD = Path(__file__).parent / "data" / "bad_trees"
FILES = sorted(BAD.glob("*.*"))


def expectation(path: Path) -> tuple[int, str, str]:
    first = path.read_text(encoding="utf-8").splitlines()[0]
    line, message, fix = first.split("expect:", 1)[1].removesuffix("-->").split("|")
    return int(line), message.strip(), fix.strip()


def test_the_corpus_is_large_and_covers_both_formats():
    assert len(FILES) >= 30
    assert {p.suffix for p in FILES} == {".xml", ".yaml"}


@pytest.mark.parametrize("path", FILES, ids=[p.name for p in FILES])
def test_bad_file_gives_its_message(path: Path):
    line, message, fix = expectation(path)
    with pytest.raises(TreeFileError) as info:
        load_tree(path)
    error = info.value
    assert (error.file, error.line) == (str(path), line)
    assert message in error.message
    assert fix in error.fix
    assert str(error) == f"{path}:{line}: {error.message}; {error.fix}"
    assert "\n" not in str(error)


@pytest.mark.parametrize("name", ["unknown_leaf.xml", "billion_laughs.xml", "not_yaml.yaml"])
def test_cli_prints_one_line_and_exits_2(name: str, capsys):
    path = BAD / name
    line, message, fix = expectation(path)
    for args in (["tree", str(path)], ["run", "gathering", "--tree", str(path), "--quiet"]):
        assert main(args) == 2
        out, err = capsys.readouterr()
        assert out == ""
        assert err.startswith(f"pyaa: error: {path}:{line}: ") and err.count("\n") == 1
        assert message in err and fix in err and "Traceback" not in err
