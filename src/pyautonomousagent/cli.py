"""The ``pyaa`` command: run scenarios, list them, and print their trees."""

from __future__ import annotations

import argparse
import difflib
import json
import logging
import os
import shutil
import sys
from collections import Counter, defaultdict
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager, nullcontext
from itertools import product
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

from pyautonomousagent import bench
from pyautonomousagent.bt.build import build
from pyautonomousagent.bt.document import Document
from pyautonomousagent.bt.files import (
    file_format,
    is_tree_file,
    read_document,
    scenario_document,
    to_text_format,
)
from pyautonomousagent.bt.leaf import LeafError
from pyautonomousagent.bt.spec import Node, TreeError
from pyautonomousagent.bt.text import to_text
from pyautonomousagent.bt.trees import tree_by_name
from pyautonomousagent.experiments.backends import BackendError
from pyautonomousagent.experiments.expression import ExpressionError
from pyautonomousagent.folders import Claim, hidden_folder, recover
from pyautonomousagent.inputs import InputError, clip, finite, shown
from pyautonomousagent.names import AgentNames
from pyautonomousagent.recording import (
    DEFAULT_TRACED,
    Recorder,
    traced_agents,
)
from pyautonomousagent.runs import (
    RunError,
    SavedRun,
    SaveError,
    add_files,
    check_output,
    check_target,
    claim_existing,
    claim_run,
    default_folder,
    last_recorded,
    save_run,
    simulate,
    streaming,
    verify,
)
from pyautonomousagent.scenarios import load, names
from pyautonomousagent.simulation import Scenario, ScenarioError, Simulation
from pyautonomousagent.simulation.run import ENGINES
from pyautonomousagent.simulation.scenario import to_mapping

if TYPE_CHECKING:
    from pyautonomousagent.render.views import Views

#: Errors that mean bad input: shown as one line, no traceback (TreeFileError is a TreeError;
#: ScenarioError and the runs' RunError are InputErrors; the experiments' ExpressionError is a
#: bad measure expression, BackendError a backend that fails).
USER_ERRORS = (InputError, TreeError, LeafError, ExpressionError, BackendError)
#: A subcommand: the parsed arguments -> the exit status.
Command = Callable[[argparse.Namespace], int]


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error on one line."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def world_size(text: str) -> list[float]:
    """``--world``: ``"WIDTH,HEIGHT"`` -> [width, height] (world units; the scenario checks
    that they are finite and above 0)."""
    parts = text.replace("x", ",").split(",")
    try:
        size = [float(part) for part in parts]
    except ValueError:
        size = []
    if len(size) != 2:
        raise argparse.ArgumentTypeError(f"WIDTH,HEIGHT in world units, e.g. 500,400; got {text!r}")
    return size


def _int_list(text: str) -> list[int]:
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        message = f"expected whole numbers separated by commas, got {text!r}"
        raise argparse.ArgumentTypeError(message) from None
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"expected whole numbers >= 1, got {text!r}")
    return values


#: The converters that :data:`COMMANDS` names as ``type=NAME``.
TYPES: dict[str, Callable[[str], Any]] = {
    "int": int, "float": float, "Path": Path, "world_size": world_size, "int_list": _int_list,
}  # fmt: skip
SCENARIO = "a registered scenario name or a scenario .yaml file"
ENGINE_OPTION = "--engine choices=auto,ENGINES"
RUN_DIR = "run_dir type=Path metavar=RUN_DIR"

#: pyaa's subcommands, in the order ``pyaa --help`` lists them: "" -> the subcommand's help,
#: then each argument -> its help. An argument is its flag (or a positional's name) and
#: add_argument's settings as KEY=VALUE: ``type`` names one of :data:`TYPES` (a default is
#: converted by it), ``choices`` are comma-separated (ENGINES: the registered engines),
#: ``action=append`` starts from [], and ``group=NAME`` puts the options of one NAME into
#: one mutually exclusive group.
COMMANDS: dict[str, dict[str, str]] = {
    "scenarios": {
        "": "list the registered scenarios, or show one with its parameters",
        "name nargs=?": "a scenario name or .yaml file: its mission, world and parameters",
    },
    "run": {
        "": "run a scenario and write its data and animation",
        "scenario": SCENARIO,
        "--agents type=int": "number of agents (default: the scenario's)",
        "--iterations type=int": "iterations to simulate",
        "--world type=world_size metavar=WIDTH,HEIGHT": "the world's size in world units, e.g. "
        "500,400 (default: the scenario's)",
        "--seed type=int default=0": "seed of the run's random generator",
        f"{ENGINE_OPTION} default=auto": "decision engine (default auto: compiled for long runs "
        "and trees compiled before, pytrees for hand-written leaves, else batched)",
        "--out type=Path": "output folder (default: runs/SCENARIO)",
        "--overwrite action=store_true": "replace the earlier run in the output folder (by "
        "default it is kept and the run refused)",
        "--format choices=parquet,csv default=parquet": "data format",
        "--record-every type=int default=1 metavar=K": "record every K-th iteration (default: "
        "1, all; longer than the run: the initial and final state)",
        "--no-gif action=store_true": "skip the animation (Phase 7)",
        "--frame-every type=int": "iterations between animation frames",
        "--set action=append metavar=KEY=VALUE": "override a scenario parameter, e.g. --set "
        "low_energy_threshold=30",
        "--quiet action=store_true": "no progress bar or summary",
        "--tree metavar=FILE|NAME": "run this tree instead: a tree file (.xml, .yaml) or a "
        "built-in tree (gathering, patrol)",
        "--trace metavar=AGENTS": "agents whose node statuses are recorded: names "
        "(drone2,drone7), a count, all, or 0 (default: all of a swarm of at most 10, else the "
        "first 10)",
        "--video choices=gif,mp4 default=gif": "animation format (default gif)",
        "--follow metavar=AGENT": "the agent the animation's panel shows (default: first)",
        "--inset action=store_true": "draw the followed agent's tree beside the map",
        "--no-replay action=store_true": "do not write replay.html",
        "--btlog action=append metavar=AGENT": "also write AGENT.btlog, the agent's trace as a "
        "Groot2 log (repeatable)",
    },
    "leaves": {
        "": "list the leaves a scenario's tree may use, with their docs and ports",
        "scenario": SCENARIO,
    },
    "bench": {
        "": "time and peak memory per engine (paper Tables 4, 5)",
        "scenario": "a registered scenario name",
        "--agents type=int_list": "agent counts, e.g. 1,10,100,1000 (default: those for the "
        "paper's tables, else the scenario's own)",
        "--iterations type=int": "iterations per run (default: 4000 for the paper's tables, else "
        "the scenario's)",
        "--save action=store_true": "also write each run's data and views as pyaa run does (to "
        "a temporary folder) and time the writing and the views",
        "--engines": "engines, comma-separated; the first is the reference of the speed-ups "
        "(default: pytrees,batched; pyfly,batched for the X8)",
        "--record-every type=int_list metavar=K[,K...]": "recording decimation(s) to measure, "
        "e.g. 1,100 (default 1)",
        "--reference-iterations type=int metavar=K": "run the reference engine K iterations "
        "only and scale its time (marked ~)",
        "--compare action=append metavar=NAME:KEY=VALUE[,KEY=VALUE...]": "measure every case in "
        "variants with these parameter values (repeat the option; NAME: alone is the scenario "
        "as it is): the variants alternate (A B A B ...) --repeat times; the table gives each "
        "one's best loop time and peak memory and their ratios to the first variant's",
        "--repeat type=int default=1 metavar=R": "measure every case R times",
        "--bandwidth type=float metavar=GBPS": "the GPU's measured memory bandwidth in GB/s "
        "(scripts/gpu_figures.py bandwidth): the GPU cases also give the share of it their "
        "bytes per drone-iteration make",
        "--json action=store_true": "print JSON instead of a table",
        "--timeout type=float": "give up on a case after this many seconds",
        "--stress action=store_true": "find the largest swarm within --memory-budget (per engine)",
        "--memory-budget default=5.12GB": "peak memory allowed, e.g. 5.12GB",
        "--stress-start type=int default=1000 metavar=N": "agents of the first stress probe",
        "--stress-iterations type=int default=20 metavar=K": "iterations of each stress probe "
        "(memory is preallocated)",
    },
    "replay": {
        "": "write replay.html (and Groot2 logs) of a finished run",
        RUN_DIR: "a folder pyaa run wrote",
        "--out type=Path": "the page to write (default RUN_DIR/replay.html)",
        "--btlog action=append metavar=AGENT": "also write RUN_DIR/AGENT.btlog for Groot2 (a "
        "traced agent; repeatable)",
    },
    "verify": {
        "": "check a run folder against its run.json (exit 0, or 1 naming what differs)",
        RUN_DIR: "a folder pyaa run wrote",
    },
    "sweep": {
        "": "run a parameter sweep with seeds, one row per run",
        "experiment": "an experiment .yaml file, or a scenario to sweep",
        "--vary action=append metavar=NAME=V1,V2|FROM:TO:STEP": "a parameter to vary (several: "
        "a grid), e.g. refuel_rate=1:3:1",
        "--design choices=grid,lhs,sobol,morris": "grid (default: every combination of --vary) "
        "or a sampled design over bounds (--vary NAME=LOW:HIGH)",
        "--samples type=int metavar=N": "a sampled design's N (sobol: a power of 2)",
        "--design-seed type=int": "the sampled design's seed (default 0)",
        "--seeds type=int": "seeds 0..N-1 per point (default 1)",
        "--iterations type=int": "iterations per run",
        "--agents type=int": "agents per run",
        "--set action=append metavar=KEY=VALUE": "a fixed override for every run",
        "--measure action=append metavar=NAME|NAME=EXPR": "a registered measure or "
        "NAME=expression (default: all registered)",
        ENGINE_OPTION: "decision engine",
        "--record-every type=int metavar=K": "record every K-th iteration",
        "--every type=int metavar=K": "also keep each measure every K iterations per run "
        "(OUT/timeseries.parquet)",
        "--out type=Path": "sweep folder (default: runs/sweeps/NAME)",
        "--workers type=int": "local processes (default: all cores)",
        "--dask metavar=ADDRESS|local group=where": "run on a Dask cluster (scheduler address) "
        "or a local Dask cluster",
        "--serial action=store_true group=where": "run in this process, one by one",
        "--resume action=store_true": "continue the sweep in --out",
        "--save-runs action=store_true": "also write each run's data under OUT/runs "
        "(hive-partitioned)",
        "--quiet action=store_true": "no progress bar or summary",
    },
    "plot": {
        "": "plot a measure of a sweep against a parameter",
        "sweep type=Path": "a sweep folder (or its results.parquet)",
        "--measure required=true": "the measure (a results column)",
        "--x": "the parameter on the horizontal axis (not with --over-time)",
        "--by": "a second parameter: one line per value",
        "--over-time action=store_true": "the measure over the iterations, one line per value "
        "of --by (or the only varied parameter), from a sweep run with --every",
        "--interval default=ci95 choices=ci95,sd,range,none": "the band: 95%% CI of the mean "
        "(default), sd, min-max, none",
        "--out type=Path": "picture file, .png or .svg",
    },
    "measures": {"": "list the registered measures"},
    "analyse": {
        "": "Sobol or Morris sensitivity indices of a sweep run with such a design",
        "sweep type=Path": "a sweep folder (--design sobol or morris)",
        "--measure action=append metavar=M": "a measure to analyse (several: one each; default: "
        "every measure of the sweep)",
        "--out type=Path": "picture file, .png or .svg (default SWEEP/sensitivity.png)",
    },
    "studio": {
        "": "build a tree from blocks in the browser, run it live",
        "scenario nargs=? default=gathering": f"{SCENARIO} (default: gathering)",
        "--port type=int default=8765": "port (default 8765; 0: any)",
        "--host default=127.0.0.1": "address (default 127.0.0.1)",
        "--no-browser action=store_true": "do not open a browser",
    },
    "tree": {
        "": "print, draw or convert a behaviour tree",
        "source metavar=FILE_OR_SCENARIO": "a tree file (.xml, .yaml, .yml), a registered "
        "scenario or a scenario .yaml file",
        "--format choices=text,png,svg,dot,xml,yaml default=text": "text (default), a png/svg "
        "picture, Graphviz dot, or a tree file (xml, yaml)",
        "--out type=Path": "write to this file (pictures: default NAME.png)",
        "--style choices=paper,py_trees default=paper": "text format: the paper's symbols, or "
        "py_trees' own drawing",
    },
}


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="pyaa", description="Model autonomous agents with behaviour trees.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for command, table in COMMANDS.items():
        _add_arguments(sub.add_parser(command, help=table[""]), table)
    return parser


def _add_arguments(parser: argparse.ArgumentParser, table: Mapping[str, str]) -> None:
    """Add the arguments of one of :data:`COMMANDS`' tables (all but its "" entry)."""
    groups: defaultdict[str, Any] = defaultdict(parser.add_mutually_exclusive_group)
    for spec, text in list(table.items())[1:]:
        name, *settings = spec.split()
        kwargs: dict[str, Any] = dict(setting.split("=", 1) for setting in settings)
        if "type" in kwargs:
            kwargs["type"] = TYPES[kwargs["type"]]
            if "default" in kwargs:
                kwargs["default"] = kwargs["type"](kwargs["default"])
        if "choices" in kwargs:
            kwargs["choices"] = kwargs["choices"].replace("ENGINES", ",".join(ENGINES)).split(",")
        if kwargs.get("action") == "append":
            kwargs["default"] = []
        if "required" in kwargs:
            kwargs["required"] = kwargs["required"] == "true"
        target = groups[kwargs.pop("group")] if "group" in kwargs else parser
        target.add_argument(name, help=text, **kwargs)


def verify_command(args: argparse.Namespace) -> int:
    """``pyaa verify``: one line; exit 0 where every file ``run.json`` lists is there with its
    size and hash (:func:`pyautonomousagent.runs.verify`), else 1 naming what differs."""
    folder: Path = args.run_dir
    try:
        summary = verify(folder)
    except RunError as error:
        print(f"pyaa: {clip(str(error))}", file=sys.stderr)
        return 1
    scenario = summary.get("scenario", {})
    name = scenario.get("name", "?") if isinstance(scenario, dict) else "?"
    print(
        f"{folder}: {summary.get('status', '?')} run of {name}, seed {summary.get('seed', '?')}, "
        f"{summary.get('iterations_done', '?')} iterations; its {len(summary['files'])} files "
        "match run.json"
    )
    return 0


def studio_command(args: argparse.Namespace) -> int:
    """``pyaa studio``: serve the studio in the current folder until Ctrl-C."""
    from pyautonomousagent.studio import Studio, has_bundle

    if not has_bundle():
        print(
            "pyaa: error: the studio's front-end is not built; run 'make demo' (or: cd studio "
            "&& npm ci && npm run build)", file=sys.stderr,
        )  # fmt: skip
        return 2
    if not 0 <= args.port <= 65535:
        raise InputError(f"--port must be a whole number from 0 to 65535, got {args.port}")
    studio = Studio(args.scenario, Path.cwd(), args.host, args.port)
    print(f"pyaa studio: {studio.url} (scenario {args.scenario}; Ctrl-C stops it)", flush=True)
    if not args.no_browser:
        import webbrowser

        webbrowser.open(studio.url)
    studio.serve()
    return 0


def _bench_engines(args: argparse.Namespace, scenario: Scenario) -> list[str]:
    default = "pyfly,batched" if scenario.model == "x8" else "pytrees,batched"
    engines = [e.strip() for e in (args.engines or default).split(",") if e.strip()]
    unknown = [e for e in engines if e not in bench.BENCH_ENGINES]
    if unknown or not engines:
        raise ScenarioError(
            f"--engines: unknown engine {(unknown or [''])[0]!r}; "
            f"choose from {', '.join(bench.BENCH_ENGINES)}"
        )
    return engines


def bench_command(args: argparse.Namespace) -> int:
    """``pyaa bench``: measure each case in its own process, print the table (or JSON)."""
    scenario = load(args.scenario)
    engines = _bench_engines(args, scenario)
    _bench_defaults(args, scenario)
    _check_whole(args, "iterations", "reference_iterations", "stress_iterations", "stress_start")
    if args.timeout is not None and not (finite(args.timeout) and args.timeout > 0):
        raise ScenarioError(f"--timeout must be a number of seconds > 0, got {args.timeout}")
    if args.bandwidth is not None and not (finite(args.bandwidth) and args.bandwidth > 0):
        raise ScenarioError(f"--bandwidth must be GB/s > 0, got {args.bandwidth}")
    try:  # checked whether or not --stress uses it, so a typo is never ignored
        args.memory_budget_mb = bench.parse_size_mb(args.memory_budget)
    except ValueError as error:
        raise ScenarioError(f"--memory-budget: {error}") from None
    if args.stress:
        return _stress(args, engines)
    short = args.reference_iterations
    variants = _bench_variants(args, scenario)
    _note_grown_worlds(scenario, args.agents)
    results = []
    cases = list(product(args.record_every or [1], args.agents, engines, variants))
    for every, agents, engine, (name, parameters) in (c for _ in range(args.repeat) for c in cases):
        scaled = bool(short) and engine == engines[0] and short < args.iterations
        its = short if scaled else args.iterations
        case = bench.Case(
            args.scenario, engine, agents, its, every, args.iterations, scaled, args.save, name,
            parameters,
        )  # fmt: skip
        print(
            f"measuring {engine}{' ' + name if name else ''} with {agents} agents x {its} "
            f"iterations, record every {every} ...",
            file=sys.stderr,
            flush=True,
        )
        results.append(bench.measure(case, args.timeout))
    if args.json:
        print(json.dumps(_json_rows(results, engines[0], args.bandwidth), indent=2))
    elif args.compare:
        print(bench.compare_table(results))
    else:
        print(bench.table(results, engines[0]))
        gpu = bench.gpu_table(results, args.bandwidth)
        if gpu:
            print(gpu)
    return 0


def _json_rows(
    results: list[bench.Result], reference: str, gbps: float | None
) -> list[dict[str, Any]]:
    """``pyaa bench --json``: a row per result; a GPU case also has ``gpu_s`` (its parts,
    seconds), ``bytes_per_drone_iteration`` and, given ``--bandwidth``, ``bandwidth_gbps``
    and ``bandwidth_fraction``."""
    ratios = bench.speedups(results, reference)
    rows = []
    for r in results:
        row = {
            **vars(r.case),
            "seconds": r.full_seconds,
            "peak_mb": r.peak_mb,
            "seconds_per_agent_iteration": r.per_agent_iteration,
            "setup_s": r.setup,
            "loop_s": r.loop,
            "write_s": r.write,
            "write_thread_s": r.write_thread,
            "views_s": r.views,
        }
        if r.gpu is not None:
            row |= {"gpu_s": r.gpu, "bytes_per_drone_iteration": r.bytes_per_drone_iteration}
            if gbps is not None:
                row |= {"bandwidth_gbps": gbps, "bandwidth_fraction": r.bandwidth_fraction(gbps)}
        rows.append(row | {f"speedup_vs_{reference}": ratios.get(r.case), "error": r.error})
    return rows


def _note_grown_worlds(scenario: Scenario, agents: Sequence[int]) -> None:
    """Say on stderr where a swarm runs in a world larger than the scenario's (the mission's
    ``world_for``: crowded's lattice of positions grows with the swarm)."""
    for count in agents:
        size = scenario.mission_type.world_for(scenario, count)
        if size != scenario.world:
            print(f"{scenario.name} with {count} agents: in a world of {size[0]:g} x "
                  f"{size[1]:g} (the scenario's is {scenario.world[0]:g} x "
                  f"{scenario.world[1]:g}), which holds its layout", file=sys.stderr)  # fmt: skip


def _bench_variants(args: argparse.Namespace, scenario: Scenario) -> list[tuple[str, str]]:
    """``--compare`` as (name, "KEY=VALUE,...") pairs, each checked against the scenario
    (one variant, the scenario as it is, without the option); ``--repeat`` checked."""
    _check_whole(args, "repeat")
    variants = []
    for text in args.compare or [":"]:
        name, sep, parameters = text.partition(":")
        if not sep or not name.strip() and args.compare:
            raise ScenarioError(f"--compare needs NAME:KEY=VALUE[,...], got {shown(text)}")
        try:
            scenario.with_overrides(**bench.parse_parameters(parameters))
        except ValueError as error:
            raise ScenarioError(f"--compare {name}: {error}") from None
        variants.append((name.strip(), parameters))
    return variants


def _bench_defaults(args: argparse.Namespace, scenario: Scenario) -> None:
    """Fill in ``--agents`` and ``--iterations`` left out: the paper's table sizes (1, 10,
    100, 1000 agents x 4000 iterations) for its scenarios, else the scenario's own."""
    in_paper = scenario.name in bench.PAPER_TABLES
    if args.agents is None:
        args.agents = [1, 10, 100, 1000] if in_paper else [scenario.agents]
    if args.iterations is None:
        args.iterations = 4000 if in_paper else scenario.iterations


def _stress(args: argparse.Namespace, engines: list[str]) -> int:
    budget = args.memory_budget_mb

    def show(result: Any) -> None:
        mb = result.error if result.error else f"{result.peak_mb:.0f} MB"
        line = f"  {result.case.engine}: {result.case.agents} agents -> {mb}"
        print(line, file=sys.stderr, flush=True)

    # Without --record-every a probe records the initial state only: a run records the initial
    # and the final state (record_every past its end), and a probe stops long before the end.
    every = max(args.record_every) if args.record_every else args.iterations + 1
    recording = f"recording every {every}" if args.record_every else "recording the initial state"
    found = {}
    for engine in engines:
        if engine == "pyfly":
            print("pyfly: skipped (hours per probe; the paper's figure is 290 UAVs)", flush=True)
            continue
        found[engine], _ = bench.stress(
            args.scenario,
            engine,
            budget,
            args.stress_iterations,
            every,
            start=args.stress_start,
            report=show,
            full_iterations=args.iterations,
        )
        print(
            f"{args.scenario} on {engine}: at most {found[engine]} agents within "
            f"{budget:.0f} MB peak ({args.stress_iterations} iterations a probe of a "
            f"{args.iterations}-iteration run, {recording})",
            flush=True,
        )
    if args.json:
        print(json.dumps(found))
    return 0


#: Scenario fields that have their own option: ``--set agents=5`` points there.
OPTIONS = {"agents": "--agents", "iterations": "--iterations", "frame_every": "--frame-every",
           "tree": "--tree", "size": "--world", "world": "--world"}  # fmt: skip


def _parse_overrides(pairs: list[str], known: list[str] | None = None) -> dict[str, Any]:
    """``["a=1", "b=x"]`` -> ``{"a": 1, "b": "x"}`` (values read as YAML scalars); names
    are checked against ``known`` when given."""
    from pyautonomousagent.inputs import load_yaml

    values = {}
    for pair in pairs:
        key, sep, text = pair.partition("=")
        key = key.strip()
        if not sep or not key or not text.strip():
            raise ScenarioError(f"--set needs KEY=VALUE with a value, got {shown(pair)}")
        if known is not None and key in OPTIONS:
            raise ScenarioError(f"--set {key}: use the option {OPTIONS[key]} {text.strip()}")
        if known is not None and key not in known:
            close = difflib.get_close_matches(key, known, n=1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise ScenarioError(
                f"--set: unknown parameter {shown(key)}; {hint}parameters: {', '.join(known)}"
            )
        try:
            values[key] = load_yaml(text, f"--set {key}")
        except InputError as error:
            raise ScenarioError(f"{error}") from None
    return values


def _scenario(args: argparse.Namespace) -> tuple[Scenario, dict[str, Any]]:
    """The scenario ``pyaa run`` runs, and its overrides (``--set``)."""
    scenario = load(args.scenario)
    overrides = _parse_overrides(args.set, list(to_mapping(scenario)["parameters"]))
    return scenario.with_overrides(
        agents=args.agents, iterations=args.iterations, frame_every=args.frame_every,
        size=args.world, **overrides,
    ), overrides  # fmt: skip


def _check_whole(args: argparse.Namespace, *options: str, minimum: int = 1) -> None:
    """Each of ``options`` given is a whole number >= ``minimum``, else one line naming it."""
    for option in options:
        value = getattr(args, option)
        if value is not None and value < minimum:
            flag = "--" + option.replace("_", "-")
            raise ScenarioError(f"{flag} must be a whole number >= {minimum}, got {value}")


def _tree_option(value: str) -> str:
    """``--tree``: a built-in tree's name (``patrol``) as it is, as a scenario's ``tree:``
    takes it, or a tree file's absolute path; refused before anything runs: a name that is
    no built-in tree (naming the closest) and a file of another ending."""
    if not Path(value).suffix:
        tree_by_name(value)
        return value
    file_format(value)
    return str(Path(value).resolve())


def run(args: argparse.Namespace) -> int:
    """``pyaa run``: simulate, then save the data, animation and ``run.json`` as one run
    folder (see :mod:`pyautonomousagent.runs`); the folder is claimed once the simulation is
    set up (bad input writes nothing) and before it runs, so a second run into it is
    refused."""
    _check_whole(args, "record_every")
    _check_whole(args, "seed", minimum=0)
    scenario, overrides = _scenario(args)
    _check_agent_options(args, scenario)
    if args.tree is not None:
        scenario = scenario.with_overrides(tree=_tree_option(args.tree))
    out = args.out or default_folder(scenario.name)
    check_target(out, overwrite=True, create=False)  # as claim_run first does, before set-up
    with nullcontext() if args.quiet else _saying_compiles():
        sim = Simulation.create(
            scenario,
            seed=args.seed,
            engine=args.engine,
            record_every=args.record_every,
            trace=_trace_spec(args),
        )
    why = getattr(sim.engine, "why_not_fused", lambda sim: "")(sim)
    if why and not args.quiet:
        print(f"pyaa: the compiled engine ticks the tree only, not whole iterations: {why}")
    with claim_run(out, args.overwrite, report=_note) as held:
        return _run_claimed(args, sim, held, overrides)


@contextmanager
def _saying_compiles() -> Iterator[None]:
    """While the body runs, show the ``pyautonomousagent.compile`` logger's lines (the
    compiled engine compiling, and how long it took) on stderr as ``pyaa: ...`` lines."""
    logger = logging.getLogger("pyautonomousagent.compile")
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("pyaa: %(message)s"))
    level = logger.level
    logger.setLevel(logging.INFO)  # (setLevel, not .level =: it clears the loggers' cache)
    logger.addHandler(handler)
    try:
        yield
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)


def _note(*texts: str) -> None:
    """Say on stderr what pyaa did by itself (e.g. what a killed run left, repaired)."""
    for text in texts:
        print(f"pyaa: {text}", file=sys.stderr)


def _run_claimed(
    args: argparse.Namespace, sim: Simulation, held: Claim, overrides: dict[str, Any]
) -> int:
    """Run ``sim`` and save the run (``overrides``: its ``--set`` values) into the claimed
    folder ``held``."""
    progress = None if not args.quiet else False
    out = held.folder
    with streaming(sim, out, args.format) as stream:
        status = simulate(sim, progress, lines=not args.quiet)  # in a log: lines after 10 s
        saved = save_run(
            sim,
            out,
            status=status,
            fmt=args.format,
            views=_views(args, progress),
            overwrite=args.overwrite,
            command=["pyaa", *sys.argv[1:]] if sys.argv else None,
            overrides=overrides,
            stream=stream,
            claim=held,
        )
    if saved.status != "complete":
        print(_not_complete(saved, last_recorded(sim), sim.scenario.iterations), file=sys.stderr)
        return 130 if saved.status == "interrupted" else 1
    if not args.quiet:
        _print_summary(sim, saved.files)
    return 0


def _not_complete(saved: SavedRun, done: int, iterations: int) -> str:
    """What ``pyaa run`` says of a run saved incomplete: the data is partial, or the data is
    complete (every iteration) and only the views failed or were interrupted."""
    note = f"; {saved.note}" if saved.note else ""
    if done < iterations:
        return (
            f"pyaa: {saved.status} after iteration {done} of {iterations} (the last one "
            f"recorded); saved a partial run marked {saved.status!r} in {saved.folder}{note}"
        )
    return (
        f"pyaa: the data is complete (all {iterations} iterations) and saved in "
        f"{saved.folder}; only the views are missing, the run is marked {saved.status!r}"
        f"{note} (pyaa replay {saved.folder} writes replay.html from the data)"
    )


def _check_agent_options(args: argparse.Namespace, scenario: Scenario) -> None:
    """``--follow``, ``--btlog`` and ``--trace`` name agents of the scenario: checked before
    the run, each error naming its option."""
    names = AgentNames(scenario.mission_type.agent_prefix, scenario.agents)
    agents = [("--follow", args.follow)] if args.follow is not None else []
    for flag, agent in [*agents, *(("--btlog", agent) for agent in args.btlog)]:
        _check_agent(flag, agent, names)
    if args.trace is None:
        return
    items = args.trace.split(",")
    if not all(item.strip() for item in items):
        raise ScenarioError(
            "--trace needs agent names, counts or 'all' separated by commas, e.g. "
            f"drone2,drone7 or 5; got {shown(args.trace)}"
        )
    try:
        traced_agents(names, items)
    except ValueError as error:
        raise ScenarioError(f"--{error}") from None


def _trace_spec(args: argparse.Namespace) -> str | None:
    """The agents to trace: ``--trace``, plus the agents ``--btlog`` and ``--inset`` need
    (the followed agent, by default the first)."""
    needed = list(args.btlog) + (["1" if args.follow is None else args.follow] * args.inset)
    if not needed:
        return args.trace
    return ",".join([args.trace or str(DEFAULT_TRACED), *needed])


def _views(args: argparse.Namespace, progress: bool | None) -> Views:
    """The views (animation, replay.html, Groot2 logs) ``args`` ask for."""
    from pyautonomousagent.render.views import Views

    return Views(
        video=None if args.no_gif else args.video,
        replay=not args.no_replay,
        btlog=args.btlog,
        follow=args.follow or 0,
        inset=args.inset,
        progress=progress,
    )


def replay_command(args: argparse.Namespace) -> int:
    """``pyaa replay``: replay.html (and Groot2 logs) of a run folder that pyaa run wrote.

    The page goes to ``--out`` (default ``RUN_DIR/replay.html``), the logs beside it; a run
    folder's own files are refused (its ``replay.html`` and logs excepted), and a page
    written into the run folder is listed in its ``run.json``."""
    folder: Path = args.run_dir
    with claim_existing(folder) as held:
        _note(*held.notes)
        if not (folder / "run.json").is_file():
            raise ScenarioError(f"{folder}: no run.json here; give a folder that pyaa run wrote")
        views = ["replay.html", *(f"{agent}.btlog" for agent in args.btlog)]
        out = check_output(args.out or folder / "replay.html", folder, views)
        for name in views[1:]:
            check_output(out.parent / name, folder, views)
        if out.parent == folder.resolve():  # ours while the claim is held
            _note(*recover(out))
        written = _replay_into(folder, out, args)
        if out.parent == folder.resolve():
            add_files(folder, written)  # run.json lists them: the folder still verifies
    for path in written:
        print(f"wrote {path}")
    return 0


def _replay_into(folder: Path, out: Path, args: argparse.Namespace) -> list[Path]:
    """Write the replay page of ``folder`` as ``out`` and its logs beside it: drawn in a
    temporary folder there, then each renamed into place (no other file is touched)."""
    from pyautonomousagent.render.views import Views, write_views
    from pyautonomousagent.run_inputs import read_recorder, read_summary

    summary = read_summary(folder)  # every file of the run checked first (run_inputs)
    scenario = Scenario.from_mapping(summary["scenario"], source=str(folder / "run.json"))
    recorder = read_recorder(folder, summary.get("trace", {}).get("nodes", []))
    _check_btlog(recorder, args.btlog)
    temp = hidden_folder(out, "tmp")
    try:
        events = summary.get("events", [])
        views = write_views(recorder, scenario, events, temp, Views(None, btlog=args.btlog))
        placed = [out] + [out.parent / path.name for path in views.written[1:]]
        for path, target in zip(views.written, placed, strict=True):
            os.replace(path, target)
    except (KeyError, ValueError) as error:  # what the run's data cannot draw: one line
        message = error.args[0] if isinstance(error, KeyError) and error.args else str(error)
        raise ScenarioError(str(message)) from None
    finally:
        shutil.rmtree(temp, ignore_errors=True)
    return placed


def _check_agent(flag: str, agent: str, names: Sequence[str]) -> None:
    """``agent``, given to option ``flag``, is one of ``names``, else one line naming them."""
    if agent not in names:
        known = f"agents are {names[0]}..{names[-1]}" if names else "the run has no agents"
        raise ScenarioError(f"{flag}: no agent named {shown(agent)}; {known}")


def _check_btlog(recorder: Recorder, agents: Sequence[str]) -> None:
    """``pyaa replay --btlog``: each agent is one of the run's, and traced; checked before
    anything is written."""
    names = list(recorder.names)
    traced = [names[i] for i in recorder.traced]
    for agent in agents:
        _check_agent("--btlog", agent, names)
        if agent not in traced:
            raise ScenarioError(
                f"--btlog: agent {agent!r} was not traced in this run (traced: "
                f"{', '.join(traced) or 'none'}); run it again with --btlog {agent}"
            )


def _print_summary(sim: Simulation, written: list[Path]) -> None:
    others = Counter(e["event"] for e in sim.events)
    alerts, messages = others.pop("alert", 0), others.pop("message", 0)
    more = "".join(f", {count} {kind}(s)" for kind, count in sorted(others.items()))
    n, its = sim.swarm.size, sim.scenario.iterations
    print(
        f"{sim.scenario.name}: {n} agents x {its} iterations on {sim.engine.name} in "
        f"{sim.timings['simulate']:.2f} s; {messages} recorded message(s), {alerts} alert(s)"
        f"{more}"
    )
    print(f"  time: {timings_line(sim.timings)}")
    for path in written:
        print(f"  wrote {path}")
    if sim.could_compile:
        print(
            "  tip: --engine compiled compiles this tree once (seconds; numba's cache keeps it) "
            "and runs it many times faster; later runs then take it by themselves"
        )


def timings_line(timings: Mapping[str, float]) -> str:
    """``set-up 0.01 s, loop 2.10 s, writing 0.05 s, views 3.20 s (animation 3.10 s, replay
    0.10 s)`` from ``Simulation.timings``; stages not done are left out. Data written while
    the loop ran: ``writing 0.05 s after the loop (thread 1.20 s)``, the thread's CPU time."""
    parts = [
        f"{label} {timings[key]:.2f} s"
        for key, label in (("setup", "set-up"), ("simulate", "loop"), ("write_data", "writing"))
        if key in timings
    ]
    if "compile" in timings and "setup" in timings:
        parts[0] += f" (of which compiling or loading the tree's code {timings['compile']:.2f} s)"
    if "write_data" in timings and "write_data_thread" in timings:
        parts[-1] += f" after the loop (thread {timings['write_data_thread']:.2f} s CPU)"
    views = {k: timings[k] for k in ("animation", "replay") if k in timings}
    if views:
        each = ", ".join(f"{k} {v:.2f} s" for k, v in views.items())
        parts.append(f"views {sum(views.values()):.2f} s ({each})")
    return ", ".join(parts)


def scenarios_command(args: argparse.Namespace) -> int:
    """``pyaa scenarios``: one line per registered scenario; with a name, that scenario's
    mission, world objects and parameters (units, ranges, values)."""
    if args.name is not None:
        print(_describe(load(args.name)))
        return 0
    width = max(12, *(len(n) for n in names()))
    for name in names():
        scenario = load(name)
        print(
            f"{name:{width}s} {scenario.agents:>5d} agents {scenario.iterations:>6d} iterations  "
            f"{scenario.description}"
        )
    return 0


def _describe(scenario: Scenario) -> str:
    """A scenario as ``pyaa scenarios NAME`` shows it."""
    from pyautonomousagent.simulation.params import plain
    from pyautonomousagent.simulation.scenario import parameter_list

    mission = scenario.mission_type
    lines = [
        f"{scenario.name}: {scenario.description}",
        f"  mission     {scenario.mission} ({mission.description})",
        f"  tree        {scenario.tree}",
        f"  agents      {scenario.agents} ({mission.agent_prefix}1..)",
        f"  iterations  {scenario.iterations}",
        f"  model       {scenario.model}",
        f"  world       {scenario.world[0]:g} x {scenario.world[1]:g}",
    ]
    for kind in mission.world_objects:
        value = json.dumps(plain(getattr(scenario.objects, kind.name)))
        lines.append(f"    {kind.name}: {value[:200]}  ({kind.doc})")
    if scenario.model_settings is not None:
        lines.append(f"  {scenario.model} settings: {json.dumps(plain(scenario.model_settings))}")
    lines.append("  parameters (set with --set NAME=VALUE; [range], default, owner):")
    values = vars(scenario.parameters)
    for owner, param in parameter_list(scenario):
        unit = f" {param.unit}" if param.unit else ""
        low = "" if param.minimum is None else f"{param.minimum:g}"
        high = "" if param.maximum is None else f"{param.maximum:g}"
        bounds = f" [{low}..{high}]" if low or high else ""
        lines.append(
            f"    {param.name} = {values[param.name]!r}{unit}{bounds}, default "
            f"{param.default!r}, {owner}: {param.doc}"
        )
    return "\n".join(lines)


def leaves_command(args: argparse.Namespace) -> int:
    """``pyaa leaves``: the leaf types that fit a scenario's mission, each with its one-line
    doc, ports (type, the scenario parameter that gives the default, its value) and
    blackboard keys; then the general leaves, which fit any mission."""
    from pyautonomousagent.simulation.fit import fitting_leaves, is_general

    scenario = load(args.scenario)
    fits = fitting_leaves(scenario)
    own = [cls for cls in fits if not is_general(cls)]
    print(
        f"{len(own)} leaves fit scenario {scenario.name} (mission "
        f"{scenario.mission_type.name}); a port left out of the tree takes the parameter shown:"
    )
    values = vars(scenario.parameters)
    for cls in own:
        print(f"  {cls.type_name}: {cls.summary()}")
        for port in cls.ports:
            doc = f"; {port.doc}" if port.doc else ""
            print(
                f"      {port.name} ({port.hint()}) = {port.default} "
                f"({values.get(port.default)!r}){doc}"
            )
        if cls.keys:
            print(f"      blackboard: {', '.join(cls.keys)}")
    general = [cls.type_name for cls in fits if is_general(cls)]
    print(f"general leaves, for any mission (docs/tree-files.md): {', '.join(general)}")
    return 0


def _tree_source(source: str) -> tuple[Document, str, dict[str, Any], Scenario | None]:
    """The tree document ``source`` names (a tree file, or a scenario's tree), a name, the
    parameters that give leaf ports their defaults (every mission's, for a bare file), and
    the scenario (None for a bare file)."""
    if source not in names() and is_tree_file(source) and not _is_scenario_file(source):
        return read_document(source), Path(source).stem, _all_defaults(), None
    looks_like_a_file = bool(Path(source).suffix) or "/" in source
    if source not in names() and looks_like_a_file and not is_tree_file(source):
        raise InputError(
            f"{shown(source)} is neither a registered scenario ({', '.join(names())}) nor a "
            "tree or scenario file; give a file ending in .xml, .yaml or .yml"
        )
    scenario = load(source)
    return scenario_document(scenario.tree), scenario.name, vars(scenario.parameters), scenario


def _all_defaults() -> dict[str, Any]:
    """The default of every parameter any registered mission or motion model declares."""
    from pyautonomousagent.simulation.mission import MISSIONS
    from pyautonomousagent.simulation.motion import MOTION_MODELS
    from pyautonomousagent.simulation.scenario import CORE_PARAMETERS

    owners: list[Any] = [*MOTION_MODELS.values(), *MISSIONS.values()]
    params = [*CORE_PARAMETERS, *(p for owner in owners for p in owner.parameters)]
    return {p.name: p.default for p in params}


def _is_scenario_file(path: str) -> bool:
    """Whether a .yaml file is a scenario (it has ``agents``) rather than a tree file."""
    if not path.endswith((".yaml", ".yml")):
        return False
    from pyautonomousagent.inputs import load_yaml, read_text

    try:
        data = load_yaml(read_text(path, "file"), path)
    except InputError:
        return False  # the tree reader reports it, with the line
    return isinstance(data, dict) and "agents" in data


def _py_trees_text(tree: Node, defaults: dict[str, Any]) -> str:
    """py_trees' own drawing of the tree, built for one agent with the parameters ``defaults``."""
    import py_trees

    from pyautonomousagent.datalink import Datalink
    from pyautonomousagent.engines.pytrees import build_behaviour
    from pyautonomousagent.state import Swarm
    from pyautonomousagent.world import World

    swarm = Swarm.create(["agent1"], {"number_ticks": int})
    world = World(100.0, 100.0, Datalink(1000.0), agent_index={"agent1": 0})
    root = build_behaviour(tree, swarm.agent(0), world, defaults)
    return str(py_trees.display.unicode_tree(root))


def tree_command(args: argparse.Namespace) -> int:
    """``pyaa tree``: print, draw or convert a tree file or a scenario's tree."""
    document, name, defaults, scenario = _tree_source(args.source)
    fmt = args.format
    if fmt in ("png", "svg"):
        from pyautonomousagent.bt.draw import draw_tree

        target = args.out or Path(f"{name}.{fmt}")
        with _writing(target):
            path = draw_tree(build(document), target, title=name)
        print(f"wrote {path}")
        return 0
    if fmt in ("xml", "yaml"):  # a scenario's tree lists the leaves that fit it, not all
        from pyautonomousagent.simulation.fit import fitting_leaves

        leaves = None if scenario is None else [cls.type_name for cls in fitting_leaves(scenario)]
        text = to_text_format(document, fmt, leaves=leaves)
    elif fmt == "dot":
        from pyautonomousagent.bt.draw import to_dot

        text = to_dot(build(document), name)
    elif args.style == "py_trees":
        text = _py_trees_text(build(document), defaults) + "\n"
    else:
        text = to_text(build(document)) + "\n"
    if args.out is None:
        print(text, end="")
        return 0
    with _writing(args.out):
        args.out.write_text(text, encoding="utf-8")
    print(f"wrote {args.out}")
    return 0


@contextmanager
def _writing(path: Path) -> Iterator[None]:
    """Write ``path`` in the body, never over a run's own files (:func:`check_output`); an
    OSError becomes one line naming the path."""
    check_output(path)
    try:
        yield
    except OSError as error:
        reason = error.strerror or type(error).__name__
        raise InputError(f"cannot write {path}: {reason}; check the folder exists") from None


# --- experiments: pyaa sweep, pyaa plot, pyaa measures (library: pyautonomousagent.experiments)


def _experiment(args: argparse.Namespace) -> Any:
    """The experiment of ``pyaa sweep``: an experiment file (a .yaml with ``scenario``) or
    a scenario to sweep, with the options added (see docs/experiments.md)."""
    from pyautonomousagent.experiments import Experiment
    from pyautonomousagent.experiments.spec import read_file, with_options

    source = args.experiment
    data: dict[str, Any] = {"scenario": source, "name": Path(source).stem + "-sweep"}
    if source.endswith((".yaml", ".yml")) and Path(source).is_file():
        loaded = read_file(source)
        if isinstance(loaded, dict) and "scenario" in loaded:
            data = {"name": Path(source).stem, **loaded}
    data |= _given(args, "design", "samples", "design_seed")
    data = with_options(data, source, args.vary, _parse_overrides(args.set))
    if args.agents is not None:
        data["set"]["agents"] = args.agents
    measures: list[Any] = []
    for text in args.measure:
        name, sep, expression = text.partition("=")
        measures.append({name: expression} if sep and name.isidentifier() else text)
    data |= _given(args, "seeds", "iterations", "engine", "record_every", "every")
    if measures:
        data["measures"] = measures
    return Experiment.from_mapping(data, source=source)


def _given(args: argparse.Namespace, *options: str) -> dict[str, Any]:
    """The ``options`` given on the command line (not None), by name."""
    return {key: getattr(args, key) for key in options if getattr(args, key) is not None}


def _inside(root: Path, name: str) -> Path:
    """``root/name``, if it stays inside ``root`` once resolved (links too)."""
    path = root / name
    if path.resolve() == root.resolve() or not path.resolve().is_relative_to(root.resolve()):
        raise ScenarioError(f"the name {name!r} would put the output outside {root}; use --out")
    return path


def sweep_command(args: argparse.Namespace) -> int:
    """``pyaa sweep``: run an experiment into a sweep folder (see docs/experiments.md)."""
    from pyautonomousagent.experiments import sweep

    if args.every is not None and args.every < 1:
        raise ScenarioError(f"--every must be a whole number >= 1 (iterations), got {args.every}")
    experiment = _experiment(args)
    out = args.out or _inside(Path("runs") / "sweeps", experiment.name)
    backend = "serial" if args.serial else "dask" if args.dask else "pool"
    address = None if args.dask in (None, "local") else args.dask
    _check_whole(args, "workers")
    try:
        result = sweep(
            experiment,
            out,
            backend,
            workers=args.workers,
            address=address,
            resume=args.resume,
            save_runs=args.save_runs,
            progress=False if args.quiet else None,
            report=_note,
        )
    except KeyboardInterrupt:
        print(
            f"pyaa: interrupted; the finished runs are kept in {out}: run the same command "
            "with --resume to continue",
            file=sys.stderr,
        )
        return 130
    if not args.quiet:
        c = result.counts
        print(
            f"sweep {experiment.name}: {sum(c.values())} runs ({c['ok']} ok, {c['failed']} "
            f"failed, {c['skipped']} done before) on {result.backend} in "
            f"{result.seconds:.1f} s\n  wrote {out / 'results.parquet'}"
            + (f"\n  wrote {out / 'timeseries.parquet'}" if experiment.every else "")
        )
    return 1 if result.counts["failed"] else 0


def plot_command(args: argparse.Namespace) -> int:
    """``pyaa plot``: a measure against a parameter, mean and interval over seeds."""
    from pyautonomousagent.experiments.plot import plot_measure

    if args.out is not None:
        check_output(args.out)  # never over a run's own files
    if args.over_time:
        return _plot_over_time(args)
    if args.x is None:
        raise ScenarioError("--x is needed: the parameter on the horizontal axis (or --over-time)")

    def show(rows: list[dict[str, Any]], by: str | None) -> None:
        for row in rows:
            _print_row(f"{by}={row['by']} " if by else "", f"{args.x}={row['x']}", row)

    path = plot_measure(args.sweep, args.measure, args.x, args.by, args.out, args.interval,
                        echo=show)  # fmt: skip
    print(f"wrote {path}")
    return 0


def _print_row(group: str, where: str, row: Mapping[str, Any]) -> None:
    """One summarised row of a plot: its runs, mean and interval."""
    print(f"{group}{where}: n={row['n']} mean={row['mean']:.6g} "
          f"[{row['low']:.6g}, {row['high']:.6g}]")  # fmt: skip


def analyse_command(args: argparse.Namespace) -> int:
    """``pyaa analyse``: print and draw a Sobol or Morris sweep's sensitivity indices."""
    from pyautonomousagent.experiments import sensitivity

    out = args.out if args.out is not None else args.sweep / "sensitivity.png"
    if out.suffix.lower() not in (".png", ".svg"):
        raise ScenarioError(f"--out {out}: use a .png or .svg name")
    check_output(out)  # never over a run's or a sweep's own files
    stored = sensitivity.read_sweep(args.sweep)
    known = list(stored.measures)
    measures = list(dict.fromkeys(args.measure)) or known
    sensitivity.check_measures(stored.results, measures, known)
    table = sensitivity.indices(stored.results, stored.design, stored.unit, measures, stored.seeds)
    for line in sensitivity.report(table, stored):
        print(line)
    path = sensitivity.plot_indices(table, stored, out)
    print(f"wrote {path}")
    return 0


def _plot_over_time(args: argparse.Namespace) -> int:
    """``pyaa plot --over-time``: a measure over the iterations, a line per parameter value."""
    from pyautonomousagent.experiments.plot import plot_over_time

    if args.x is not None or args.interval != "ci95":
        raise ScenarioError("--over-time draws iterations across and a 95 % band: leave out "
                              "--x and --interval")  # fmt: skip

    def show(rows: list[dict[str, Any]], by: str | None) -> None:
        last = max(r["iteration"] for r in rows)
        for row in (r for r in rows if r["iteration"] == last):
            _print_row(f"{by}={row['by']} " if by else "", f"iteration {last}", row)

    print(f"wrote {plot_over_time(args.sweep, args.measure, args.by, args.out, echo=show)}")
    return 0


def measures_command(args: argparse.Namespace) -> int:
    """``pyaa measures``: one line per registered measure."""
    from pyautonomousagent.experiments import MEASURES

    for name, measure in MEASURES.items():
        print(f"{name:22s} {measure.unit:12s} {measure.doc}")
    return 0


#: pyaa's subcommands (:data:`COMMANDS`) -> the function that runs one.
HANDLERS: dict[str, Command] = {
    "scenarios": scenarios_command, "run": run, "leaves": leaves_command,
    "bench": bench_command, "replay": replay_command, "verify": verify_command,
    "sweep": sweep_command, "plot": plot_command, "measures": measures_command,
    "analyse": analyse_command, "studio": studio_command, "tree": tree_command,
}  # fmt: skip


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``pyaa`` console script."""
    try:
        args = _parser().parse_args(argv)
    except SystemExit as stop:  # usage errors and --help: argparse has printed its message
        return int(stop.code or 0)
    try:
        return HANDLERS[args.command](args)
    except (*USER_ERRORS, SaveError) as error:  # bad input: 2; a run that could not be saved: 1
        print(f"pyaa: error: {clip(str(error))}", file=sys.stderr)
        return 1 if isinstance(error, SaveError) else 2
    except OSError as error:  # a path given on the command line: one line, no traceback
        where = f"{error.filename}: " if error.filename else ""
        reason = error.strerror or type(error).__name__
        print(f"pyaa: error: {clip(where + reason)}; check the path", file=sys.stderr)
        return 2
    except MemoryError:  # e.g. a huge swarm, or numba compiling a very large tree
        print("pyaa: error: out of memory; try fewer agents or iterations, --record-every, "
              "or --engine batched", file=sys.stderr)  # fmt: skip
        return 1
    except KeyboardInterrupt:
        print("pyaa: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
