"""The ``pyaa`` command: run scenarios, list them, and print their trees."""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from collections.abc import Sequence
from importlib import metadata
from pathlib import Path
from typing import Any, NoReturn

from pyautonomousagent.benchmarks_x8 import add_arguments as add_bench_arguments
from pyautonomousagent.benchmarks_x8 import run_bench
from pyautonomousagent.bt.leaf import LeafError
from pyautonomousagent.bt.spec import TreeError
from pyautonomousagent.recording import write_table
from pyautonomousagent.scenarios import load, names
from pyautonomousagent.simulation import Scenario, ScenarioError, Simulation
from pyautonomousagent.simulation.run import ENGINES
from pyautonomousagent.simulation.scenario import to_mapping

#: Errors that mean bad input: shown as one line, no traceback.
USER_ERRORS = (ScenarioError, TreeError, LeafError)


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error on one line."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="pyaa", description="Model autonomous agents with behaviour trees.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    sub.add_parser("scenarios", help="list the registered scenarios")
    run = sub.add_parser("run", help="run a scenario and write its data and animation")
    run.add_argument("scenario", help="a registered scenario name or a scenario .yaml file")
    run.add_argument("--agents", type=int, help="number of agents (default: the scenario's)")
    run.add_argument("--iterations", type=int, help="iterations to simulate")
    run.add_argument("--seed", type=int, default=0, help="seed of the run's random generator")
    run.add_argument("--engine", choices=list(ENGINES), default="pytrees", help="decision engine")
    run.add_argument("--out", type=Path, help="output folder (default: runs/SCENARIO)")
    run.add_argument("--format", choices=["parquet", "csv"], default="parquet", help="data format")
    run.add_argument(
        "--record-every",
        type=int,
        default=1,
        metavar="K",
        help="record every K-th iteration (default: 1, all)",
    )
    run.add_argument("--no-gif", action="store_true", help="skip the animation (Phase 7)")
    run.add_argument("--frame-every", type=int, help="iterations between animation frames")
    run.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a scenario parameter, e.g. --set low_energy_threshold=30",
    )
    run.add_argument("--quiet", action="store_true", help="no progress bar or summary")
    add_bench_arguments(sub.add_parser("bench", help="time and peak memory per engine and size"))
    tree = sub.add_parser("tree", help="print a scenario's behaviour tree")
    tree.add_argument("scenario", help="a registered scenario name or a scenario .yaml file")
    tree.add_argument(
        "--style",
        choices=["paper", "py_trees"],
        default="paper",
        help="the paper's symbols, or py_trees' own drawing",
    )
    return parser


def _parse_overrides(pairs: list[str]) -> dict[str, Any]:
    """``["a=1", "b=x"]`` -> ``{"a": 1, "b": "x"}`` (numbers parsed as YAML scalars)."""
    import yaml

    values = {}
    for pair in pairs:
        key, sep, text = pair.partition("=")
        if not sep or not key:
            raise ScenarioError(f"--set needs KEY=VALUE, got {pair!r}")
        values[key.strip()] = yaml.safe_load(text)
    return values


def _scenario(args: argparse.Namespace) -> Scenario:
    scenario = load(args.scenario)
    overrides = _parse_overrides(args.set)
    unknown = [k for k in overrides if k not in to_mapping(scenario)["parameters"]]
    if unknown:
        raise ScenarioError(f"--set: unknown parameter {unknown[0]!r}")
    return scenario.with_overrides(
        agents=args.agents, iterations=args.iterations, frame_every=args.frame_every, **overrides
    )


def _versions() -> dict[str, str]:
    packages = ["pyautonomousagent", "numpy", "py_trees", "pyarrow", "matplotlib", "pillow"]
    found = {"python": platform.python_version()}
    for name in packages:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return found


def run(args: argparse.Namespace) -> int:
    """``pyaa run``: simulate, write the data, ``run.json`` and the animation."""
    if args.record_every < 1:
        raise ScenarioError(f"--record-every must be a whole number >= 1, got {args.record_every}")
    scenario = _scenario(args)
    out = args.out or Path("runs") / scenario.name
    out.mkdir(parents=True, exist_ok=True)
    progress = None if not args.quiet else False
    sim = Simulation.create(
        scenario, seed=args.seed, engine=args.engine, record_every=args.record_every
    ).run(progress=progress)
    start = time.perf_counter()
    data = write_table(sim.table(), out / f"states.{args.format}", args.format)
    sim.timings["write_data"] = time.perf_counter() - start
    written = [data]
    if not args.no_gif:
        from pyautonomousagent.render.animation import write_gif

        stats = write_gif(
            sim.recorder,
            scenario,
            out / "animation.gif",
            frame_every=scenario.frame_every,
            progress=progress,
        )
        sim.timings["animation"] = stats.seconds
        written.append(stats.path)
    written.append(_write_summary(sim, args, out / "run.json"))
    if not args.quiet:
        _print_summary(sim, written)
    return 0


def _write_summary(sim: Simulation, args: argparse.Namespace, path: Path) -> Path:
    summary = {
        "scenario": to_mapping(sim.scenario),
        "seed": sim.seed,
        "engine": sim.engine.name,
        "record_every": sim.recorder.every,
        "versions": _versions(),
        "timings_s": {k: round(v, 4) for k, v in sim.timings.items()},
        "events": sim.events,
    }
    path.write_text(json.dumps(summary, indent=2) + "\n")
    return path


def _print_summary(sim: Simulation, written: list[Path]) -> None:
    alerts = sum(1 for e in sim.events if e["event"] == "alert")
    messages = sum(1 for e in sim.events if e["event"] == "message")
    n, its = sim.swarm.size, sim.scenario.iterations
    print(
        f"{sim.scenario.name}: {n} agents x {its} iterations on {sim.engine.name} in "
        f"{sim.timings['simulate']:.2f} s; {messages} recorded message(s), {alerts} alert(s)"
    )
    for path in written:
        print(f"  wrote {path}")


def scenarios_command() -> int:
    """``pyaa scenarios``: one line per registered scenario."""
    for name in names():
        scenario = load(name)
        print(
            f"{name:12s} {scenario.agents:>5d} agents {scenario.iterations:>6d} iterations  "
            f"{scenario.description}"
        )
    return 0


def tree_command(args: argparse.Namespace) -> int:
    """``pyaa tree``: the scenario's tree as text."""
    from pyautonomousagent.bt.text import to_text
    from pyautonomousagent.bt.trees import tree_by_name

    scenario = load(args.scenario)
    tree = tree_by_name(scenario.tree)
    if args.style == "paper":
        print(to_text(tree))
        return 0
    import py_trees

    sim = Simulation.create(scenario.with_overrides(agents=1, iterations=1), tree=tree)
    print(py_trees.display.unicode_tree(sim.engine.roots[0]))  # type: ignore[attr-defined]
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``pyaa`` console script."""
    try:
        args = _parser().parse_args(argv)
    except SystemExit as stop:  # usage errors and --help: argparse has printed its message
        return int(stop.code or 0)
    try:
        if args.command == "run":
            return run(args)
        if args.command == "scenarios":
            return scenarios_command()
        if args.command == "bench":
            return run_bench(args)
        return tree_command(args)
    except USER_ERRORS as error:
        print(f"pyaa: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("pyaa: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
