"""No traceback on malformed input, anywhere (issue 29).

Every ``pyaa`` subcommand (listed from the argparse parser itself, so a new one must be
added here) gets each of its options and positionals set to malformed values (wrong types,
NaN, inf, negative, 0, huge, text, empty, stray commas) and, for ``run``, ``sweep`` and
``bench``, every parameter of the scenario's schema through ``--set`` / ``--vary``. Each
call must end with exit status 0 (accepted) or 2 with one line on stderr, never with an
exception. Where the input is accepted, the expensive part (the simulation, the sweep, the
benchmark, the drawing) is replaced by a stub: reaching it means every check passed, which
is all this test asks (the checks must come before the work).

The public API gets the same treatment: every parameter of every scenario through
``Scenario.with_overrides``, and ``Simulation.create``'s and ``save_run``'s arguments.
"""

from __future__ import annotations

import argparse
import contextlib
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from pyautonomousagent import cli
from pyautonomousagent.inputs import InputError
from pyautonomousagent.runs import RunError, save_run
from pyautonomousagent.scenarios import load, names
from pyautonomousagent.simulation import ScenarioError, Simulation
from pyautonomousagent.simulation.scenario import parameter_list

#: Malformed command-line values.
BAD_TEXT = ["nan", "inf", "-inf", "-1", "0", "1e400", str(10**30), "abc", "", ",,", "1,,2",
            "=", "x=", ":", "../..", "1,nan", "-1,-1", "0,0", "1e400,1", "status",
            "nobody"]  # fmt: skip
#: Malformed values of a parameter (through --set / --vary and the Python API).
BAD_VALUES: list[Any] = [math.nan, math.inf, -math.inf, -1, 0, 10**30, 10**400, 1e308, "abc",
                         "", [1], True, {"a": 1}]  # fmt: skip
#: A valid call of each subcommand, to which one malformed value is added.
BASE = {
    "scenarios": ["scenarios"],
    "leaves": ["leaves", "gathering"],
    "run": ["run", "gathering", "--iterations", "3", "--engine", "batched", "--quiet"],
    "bench": ["bench", "gathering", "--agents", "1", "--iterations", "2", "--engines", "batched"],
    "replay": ["replay", "RUN"],
    "verify": ["verify", "RUN"],
    "sweep": ["sweep", "gathering", "--vary", "refuel_rate=1,2", "--iterations", "2", "--serial"],
    "plot": ["plot", "SWEEP", "--measure", "minimum_energy", "--x", "refuel_rate"],
    "measures": ["measures"],
    "analyse": ["analyse", "DESIGN"],
    "tree": ["tree", "gathering"],
    "studio": ["studio", "gathering", "--no-browser", "--port", "0"],
}


class AcceptedError(Exception):
    """Raised by the stubs: the input passed every check and the work would start."""


def _accept(*args: Any, **kwargs: Any) -> Any:
    raise AcceptedError


@pytest.fixture(scope="module")
def folders(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """A run folder, a sweep folder and a sweep folder of a Sobol design, made once."""
    root = tmp_path_factory.mktemp("inputs")
    run, sweep, design = root / "run", root / "sweep", root / "design"
    assert cli.main([*BASE["run"], "--no-gif", "--out", str(run)]) == 0
    assert cli.main([*BASE["sweep"], "--out", str(sweep), "--quiet"]) == 0
    sobol = ["--design", "sobol", "--samples", "2", "--vary", "refuel_rate=1:3"]
    assert cli.main([*BASE["sweep"][:2], *sobol, *BASE["sweep"][4:], "--out", str(design)]) == 0
    return {"RUN": str(run), "SWEEP": str(sweep), "DESIGN": str(design)}


@pytest.fixture
def stubbed(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """The work behind each subcommand replaced by :func:`_accept`; files land in tmp_path."""
    import pyautonomousagent.bench
    import pyautonomousagent.experiments
    import pyautonomousagent.experiments.plot
    import pyautonomousagent.experiments.sensitivity
    import pyautonomousagent.render.views
    import pyautonomousagent.studio

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(cli, "simulate", _accept)
    monkeypatch.setattr(pyautonomousagent.render.views, "write_views", _accept)
    monkeypatch.setattr(pyautonomousagent.bench, "measure", _accept)
    monkeypatch.setattr(pyautonomousagent.bench, "stress", _accept)
    monkeypatch.setattr(pyautonomousagent.experiments, "sweep", _accept)
    monkeypatch.setattr(pyautonomousagent.experiments.plot, "plot_measure", _accept)
    monkeypatch.setattr(pyautonomousagent.experiments.sensitivity, "plot_indices", _accept)
    monkeypatch.setattr(pyautonomousagent.studio.Studio, "serve", _accept)


def _subcommands() -> dict[str, argparse.ArgumentParser]:
    parser = cli._parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def _variants(command: str, parser: argparse.ArgumentParser) -> Iterator[list[str]]:
    """The base call of ``command`` with one option or positional made malformed."""
    base = BASE[command]
    positionals = [a for a in parser._actions if not a.option_strings and a.dest != "help"]
    for index, _ in enumerate(positionals[: len(base) - 1]):
        for text in BAD_TEXT:
            yield [*base[: index + 1], text, *base[index + 2 :]]
    for action in parser._actions:
        if action.option_strings and action.nargs != 0 and action.dest != "help":
            for text in BAD_TEXT:
                yield [*base, action.option_strings[0], text]
    if command in ("run", "sweep", "bench"):
        option = {"run": "--set", "sweep": "--vary", "bench": "--compare"}[command]
        for _, param in parameter_list(load("gathering")):
            for text in ("nan", "-inf", "-1", "0", "1e400", "1" + "0" * 400, "abc", "", "1:0:1"):
                value = f"{param.name}={text}"
                yield [*base, option, f"v:{value}" if command == "bench" else value]


def _check(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    """``pyaa ARGV`` ends with 0, or 2 and one line on stderr (``pyaa verify``: 1 and one
    line, for a folder that does not verify); never an exception."""
    try:
        code = cli.main(argv)
    except AcceptedError:
        code = 0
    except BaseException as error:  # noqa: BLE001 - the point: nothing may escape
        pytest.fail(f"pyaa {argv}: {type(error).__name__}: {error}")
    err = capsys.readouterr().err
    assert "Traceback" not in err, (argv, err)
    if code == 2:
        assert err.count("\n") == 1 and "error:" in err, (argv, err)
    elif code == 1 and argv[0] == "verify":  # a folder that does not verify: one line
        assert err.count("\n") == 1 and err.startswith("pyaa: "), (argv, err)
    else:
        assert code == 0, (argv, code, err)


def test_every_subcommand_is_covered() -> None:
    assert set(_subcommands()) == set(BASE)


@pytest.mark.parametrize("command", sorted(BASE))
def test_malformed_options_never_give_a_traceback(
    command: str, folders: dict[str, str], stubbed: None, capsys: pytest.CaptureFixture[str]
) -> None:
    parser = _subcommands()[command]
    calls = 0
    for argv in _variants(command, parser):
        _check([folders.get(word, word) for word in argv], capsys)
        calls += 1
    assert calls >= len(BAD_TEXT) or command in ("scenarios", "measures")


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # 1e308 overflows sums: no error
@pytest.mark.parametrize("name", names())
def test_malformed_parameters_through_the_api(name: str) -> None:
    """Every parameter of the scenario's schema set to each malformed value: refused with a
    ScenarioError, or accepted and then run a few iterations without an error."""
    scenario = load(name)
    small = {"iterations": 2, "agents": min(scenario.agents, 2)}
    accepted = 0
    for _, param in parameter_list(scenario):
        for value in BAD_VALUES:
            try:
                changed = scenario.with_overrides(**{param.name: value}, **small)
            except ScenarioError:
                continue
            accepted += 1
            try:
                Simulation.create(changed, engine="batched").run(progress=False)
            except InputError:
                continue
    assert accepted < len(parameter_list(scenario)) * len(BAD_VALUES)


@pytest.mark.parametrize(
    ("argument", "value"),
    [(k, v) for k in ("seed", "record_every", "engine", "trace", "tree") for v in BAD_VALUES],
)
def test_malformed_arguments_of_simulation_create(argument: str, value: Any) -> None:
    scenario = load("gathering").with_overrides(iterations=2)
    with contextlib.suppress(TypeError, ValueError):  # documented; InputError: a ValueError
        Simulation.create(scenario, **{argument: value}).run(progress=False)


@pytest.mark.parametrize("folder", [None, 42, "", ".", "..", "\n", 1e400])
def test_malformed_arguments_of_save_run(folder: Any, tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    for sim in (None, "gathering", 3.5):
        with pytest.raises(RunError):
            save_run(sim, folder)


def test_running_out_of_memory_is_one_line(monkeypatch, capsys) -> None:
    """A MemoryError where the run is made (a huge swarm; numba compiling a very large tree
    once took more than 8 GB) ends ``pyaa run`` with one line naming what to try."""

    def exhausted(*args: Any, **kwargs: Any) -> None:
        raise MemoryError

    monkeypatch.setitem(cli.HANDLERS, "run", exhausted)
    assert cli.main(["run", "gathering"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "out of memory" in err and "--engine batched" in err
