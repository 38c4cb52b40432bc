"""One studio session: a scenario, the tree being edited, its settings and the live run.

Only the public API is used (docs/studio.md). A run is saved as ``pyaa run`` saves it, from
the tree written as an XML file: the run of ``pyaa run SCENARIO --tree FILE.xml --seed S``.
"""

from __future__ import annotations

import math
import re
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pyautonomousagent.bt.spec import Node
from pyautonomousagent.bt.status import NAMES
from pyautonomousagent.inputs import InputError, shown
from pyautonomousagent.recording import node_list
from pyautonomousagent.runs import check_target, claim_run, save_run, simulate, streaming
from pyautonomousagent.scenarios import load
from pyautonomousagent.simulation import Scenario, ScenarioError, Simulation
from pyautonomousagent.simulation.scenario import parameter_list
from pyautonomousagent.studio.live import EventFeed
from pyautonomousagent.studio.trees import Block, Checked, check_blocks, plain, tree_text

#: What a saved tree or run may be called (a file or folder name in the studio's folder).
NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}")
#: Most agents a frame carries (the canvas draws the first ones of a larger swarm).
MAX_DRAWN = 5000
#: Node status codes as the recorder keeps them -> the names the page shows (its CSS classes).
STATUS_NAMES = {code: name.lower() for code, name in NAMES.items()}


@dataclass
class Settings:
    """What the parameter panel sets: parameter overrides, agents, iterations and seed."""

    parameters: dict[str, Any] = field(default_factory=dict)
    agents: int | None = None
    iterations: int | None = None
    seed: int = 0


class Session:
    """The state of one studio: the scenario, the checked tree, the settings and the run.

    Args:
        scenario: a registered scenario's name or a scenario file.
        root: the folder the studio was started in; it reads and writes only inside it.
    """

    def __init__(self, scenario: str, root: Path) -> None:
        self.base: Scenario = load(scenario)
        self.root = root.resolve()
        self.settings = Settings()
        self.scenario: Scenario = self.base
        self.checked: Checked | None = None
        self.sim: Simulation | None = None
        self.feed: EventFeed | None = None
        self.run_tree: Node | None = None  # the tree the run was made with
        #: What changed since the run on the screen began ("": it is current).
        self.stale = ""
        self.nodes: list[dict[str, Any]] = []  # the run's tree, node_list() once per run
        self.lock = threading.RLock()

    # --- settings -----------------------------------------------------------------------

    def schema(self) -> dict[str, Any]:
        """The parameter panel: each parameter's owner, type, default, unit, range and doc;
        agents, iterations and seed with the scenario's values."""
        values = vars(self.base.parameters)
        params = [
            {"name": p.name, "owner": owner, "type": p.type.__name__,
             "value": values.get(p.name, p.default),
             **{key: getattr(p, key) for key in ("default", "unit", "doc", "minimum", "maximum")}}
            for owner, p in parameter_list(self.base)
            if p.type in (int, float, str, bool)
        ]  # fmt: skip
        return {
            "scenario": self.base.name,
            "description": self.base.description,
            "agents": self.base.agents,
            "iterations": self.base.iterations,
            "seed": 0,
            "parameters": params,
        }

    def configure(self, data: Any) -> dict[str, Any]:
        """Take new settings (checked as ``pyaa run`` checks its options); a ScenarioError
        naming the field when one is bad, and nothing changes."""
        settings = read_settings(data, {p.name: p.type for _, p in parameter_list(self.base)})
        scenario = self.base.with_overrides(
            agents=settings.agents, iterations=settings.iterations, **settings.parameters
        )
        with self.lock:
            self.settings, self.scenario = settings, scenario
            self._changed()
            stale = self.stale
        return {
            "ok": True, "agents": scenario.agents, "iterations": scenario.iterations,
            "stale": stale,
        }  # fmt: skip

    # --- the tree -----------------------------------------------------------------------

    def set_tree(self, blocks: Block | None) -> Checked:
        """Check a tree of blocks; a tree that can run is the one the next run (Reset) runs,
        one that cannot keeps no tree, so nothing new runs (see :meth:`_changed` for the
        run under way)."""
        checked = check_blocks(blocks, self.scenario)
        with self.lock:
            self.checked = checked
            self._changed()
        return checked

    def _changed(self) -> None:
        """After a change of the tree or the settings: a run still at iteration 0 is
        dropped (the next step starts the new one); a run under way stays on the screen,
        can no longer be played or stepped, and :attr:`stale` says what changed, so that the
        page offers Reset. A change undone (the same tree and settings as the run's) makes
        the run current again."""
        sim = self.sim
        if sim is None:
            self.stale = ""
            return
        changed = []
        if self.checked is None or self.checked.tree != self.run_tree:
            changed.append("the tree")
        if (self.scenario, self.settings.seed) != (sim.scenario, sim.seed):
            changed.append("the parameters")
        if changed and sim.world.iteration == 0:
            self.sim = self.feed = None
            changed = []
        self.stale = f"{' and '.join(changed)} changed during this run" if changed else ""

    def tree_file(self, fmt: str) -> str:
        """The checked tree as the text of an XML or YAML file."""
        document = self.runnable().document
        assert document is not None
        return tree_text(document, fmt, self.scenario)

    def runnable(self) -> Checked:
        """The checked tree; InputError with the loader's message when it cannot run."""
        checked = self.checked
        if checked is None or checked.tree is None:
            why = checked.error if checked is not None else "no tree yet"
            raise InputError(f"the tree cannot run: {why}")
        return checked

    # --- the live run -------------------------------------------------------------------

    def reset(self) -> Simulation:
        """A new run of the checked tree with the settings, at iteration 0."""
        tree = self.runnable().tree
        with self.lock:
            self.sim = Simulation.create(self.scenario, seed=self.settings.seed, tree=tree)
            self.run_tree, self.stale = tree, ""
            self.feed = EventFeed(self.sim)
            self.nodes = node_list(self.sim.recorder.nodes)
            return self.sim

    def iteration(self) -> int:
        """The iteration the run has reached (0: no run yet)."""
        sim = self.sim
        return 0 if sim is None else int(sim.world.iteration)

    def current(self) -> None:
        """InputError when the run on the screen is not of the tree and settings now (it
        cannot go on: Reset starts the new one)."""
        if self.stale:
            raise InputError(f"{self.stale}: Reset runs the new one from iteration 0")

    def advance(self, iterations: int) -> int:
        """Run up to ``iterations`` more iterations (a new run first if there is none);
        returns the iteration reached."""
        with self.lock:
            self.current()
            sim = self.sim or self.reset()
            if iterations > 0 and sim.world.iteration < sim.scenario.iterations:
                sim.run(progress=False, iterations=iterations)
            return int(sim.world.iteration)

    def frame(self, follow: int | None = None) -> dict[str, Any]:
        """What the canvas draws now: positions and headings, the marks, the followed
        agent's node statuses, per node how many agents have it active, and the run's
        events (:meth:`EventFeed.frame`: counts for the plots, the recent ones placed)."""
        with self.lock:
            sim, feed = self.sim, self.feed
            if sim is None or feed is None:
                return {"iteration": 0, "running": False, "stale": ""}
            return {**frame_of(sim, follow, self.nodes), **feed.frame(), "stale": self.stale}

    # --- saving -------------------------------------------------------------------------

    def save_tree(self, name: str, fmt: str) -> Path:
        """Write the checked tree as ``NAME.xml`` or ``NAME.yaml`` in the studio's folder."""
        if fmt not in ("xml", "yaml"):
            raise InputError(f"a tree is saved as xml or yaml, got {shown(fmt)}")
        text = self.tree_file(fmt)
        path = self.inside(name, f".{fmt}")
        path.write_text(text, encoding="utf-8")
        return path

    def save_run(self, name: str, overwrite: bool = False) -> dict[str, Any]:
        """Save the run as ``pyaa run`` does, into ``runs/NAME``: the tree is written to
        ``NAME.xml`` and run from it, with the settings, to its last iteration."""
        self.runnable()
        out = self.inside(name, "", "runs")
        check_target(out, overwrite)  # before anything is written
        tree = self.save_tree(name, "xml")
        scenario = self.scenario.with_overrides(tree=str(tree))
        sim = Simulation.create(scenario, seed=self.settings.seed)
        command = ["pyaa", "studio", self.base.name, "--tree", str(tree)]
        command += ["--seed", str(self.settings.seed)]
        with claim_run(out, overwrite) as held, streaming(sim, held.folder) as stream:
            status = simulate(sim, progress=False)
            saved = save_run(
                sim, held.folder, status=status, command=command, claim=held,
                overrides=self.settings.parameters, stream=stream, overwrite=overwrite,
            )  # fmt: skip
        return {
            "folder": str(saved.folder.relative_to(self.root)),
            "tree": tree.name,
            "status": saved.status,
            "files": [p.name for p in saved.files],
        }

    def inside(self, name: str, suffix: str, folder: str = "") -> Path:
        """``root/folder/NAME+suffix``, refusing a name that could leave the folder."""
        if not isinstance(name, str) or not NAME.fullmatch(name):
            raise InputError(
                f"a name is 1-64 letters, digits, - and _ (starting with a letter or "
                f"digit), got {shown(name)}"
            )
        path = (self.root / folder / f"{name}{suffix}").resolve()
        if not path.is_relative_to(self.root):
            raise InputError(f"{name} is outside the studio's folder {self.root}")
        return path


def read_settings(data: Any, types: dict[str, type]) -> Settings:
    """Settings from the browser's JSON, each value checked: a known parameter, a finite
    number of its type, whole numbers for agents, iterations and seed."""
    if not isinstance(data, dict):
        raise ScenarioError("settings are a mapping of parameters, agents, iterations, seed")
    params = data.get("parameters") or {}
    if not isinstance(params, dict):
        raise ScenarioError("parameters are a mapping of name to value")
    values = {}
    for key, value in params.items():
        if key not in types:
            raise ScenarioError(f"unknown parameter {shown(key)}")
        values[key] = _value(key, value, types[key])
    agents = _whole(data.get("agents"), "agents", 1)
    iterations = _whole(data.get("iterations"), "iterations", 0)
    seed = _whole(data.get("seed", 0), "seed", 0)
    return Settings(values, agents, iterations, 0 if seed is None else seed)


def _value(key: str, value: Any, kind: type) -> Any:
    """``value`` as a parameter of type ``kind``, or a ScenarioError naming ``key``."""
    if kind in (str, bool):
        if not isinstance(value, kind):
            what = "text" if kind is str else "true or false"
            raise ScenarioError(f"{key} must be {what}, got {shown(value)}")
        return value
    number = _number(value, key)
    if kind is int:
        if number != int(number):
            raise ScenarioError(f"{key} must be a whole number, got {shown(value)}")
        return int(number)
    return float(number)


def _number(value: Any, key: str) -> float:
    """A finite number from a JSON number or a text field; ScenarioError otherwise."""
    try:
        number = float(value) if not isinstance(value, bool) else math.nan
    except (TypeError, ValueError):
        number = math.nan
    if not math.isfinite(number):
        raise ScenarioError(f"{key} must be a finite number, got {shown(value)}")
    return number


def _whole(value: Any, key: str, least: int) -> int | None:
    """A whole number >= ``least`` (None: the scenario's value)."""
    if value is None or value == "":
        return None
    number = _number(value, key)
    if number != int(number) or number < least:
        raise ScenarioError(f"{key} must be a whole number >= {least}, got {shown(value)}")
    return int(number)


def frame_of(sim: Simulation, follow: int | None, nodes: list[dict[str, Any]]) -> dict[str, Any]:
    """The drawing of ``sim`` now (see :meth:`Session.frame`); ``nodes`` is
    ``node_list(sim.recorder.nodes)``, which the session makes once per run."""
    swarm = sim.swarm
    columns = swarm.columns
    frame: dict[str, Any] = {
        "iteration": int(sim.world.iteration),
        "iterations": int(sim.scenario.iterations),
        "world": [float(sim.scenario.world[0]), float(sim.scenario.world[1])],
        "x": _rounded(columns["x"]),
        "y": _rounded(columns["y"]),
        "heading": _rounded(columns["heading"], 1) if "heading" in columns else [],
        "energy": _energy(columns["energy"]) if "energy" in columns else None,
        "altitude": _rounded(columns["z"]) if "z" in columns else [],
        "active": active_counts(sim, nodes),
    }
    if follow is not None and 0 <= follow < swarm.size:
        frame["follow"] = {
            "agent": swarm.names[follow],
            "statuses": statuses_of(sim, follow),
            "blackboard": {k: plain(v[follow]) for k, v in swarm.blackboard.items()},
        }
    frame["nodes"] = [{k: n[k] for k in ("name", "type", "depth")} for n in nodes]
    return frame


def _rounded(values: np.ndarray, decimals: int = 3) -> list[float]:
    """Values for drawing, 3 decimals (the canvas needs no more; headings, in degrees, 1)."""
    array = np.asarray(values, dtype=np.float64)[:MAX_DRAWN]
    rounded: list[float] = np.round(array, decimals).tolist()
    return rounded


def _energy(values: np.ndarray) -> dict[str, float] | None:
    """The swarm's mean and lowest energy (percent) for the plot; None for no agents."""
    array = np.asarray(values, dtype=np.float64)
    if array.size == 0:
        return None
    return {"mean": round(float(array.mean()), 3), "low": round(float(array.min()), 3)}


def statuses_of(sim: Simulation, agent: int) -> list[str] | None:
    """The status of each node (tick order) for ``agent`` at the last record, or None when
    the agent is not traced."""
    try:
        trace = sim.recorder.trace(agent)
    except KeyError:
        return None
    return [STATUS_NAMES.get(int(code), "invalid") for code in trace[-1]]


def active_counts(sim: Simulation, nodes: list[dict[str, Any]]) -> list[int]:
    """Per node (tick order), how many agents have it active at the last record: the
    agent's active leaf and the nodes above it (``nodes``: ``node_list`` of the run's)."""
    recorder = sim.recorder
    behaviour = recorder.behaviour
    if behaviour is None or recorder.count == 0 or not nodes:
        return [0] * len(nodes)
    leaves = np.asarray(behaviour[recorder.count - 1])
    total = np.bincount(leaves[leaves >= 0].astype(np.intp), minlength=len(nodes))
    for i in range(len(nodes) - 1, 0, -1):  # children come after their parent
        parent = int(nodes[i]["parent"])
        if parent >= 0:
            total[parent] += total[i]
    return [int(v) for v in total]
