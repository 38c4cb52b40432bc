"""The built-in missions, each in its own folder with its scenario files and tree files.

- ``gathering`` (the paper's Fig. 6) and ``patrol`` (Fig. 12; also flown by the Skywalker X8
  in ``x8-patrol``, whose mission of the same name lands to refuel) share the paper's drones
  (:mod:`pyautonomousagent.missions.drones`);
- ``gathering-3d`` and ``patrol-3d``: the same missions flown by the 3-D drone
  (:mod:`pyautonomousagent.missions.drones3d`, docs/drone3d.md);
- ``vacuum``: the paper's Fig. 2 robot with a sonar;
- ``radiation-search``: drones that wander, find a radiation source and call the others;
- ``crowded``: groups of drones share surveillance positions and collide (``crowded-avoid``:
  with collision avoidance in the tree).

Each is written with the public API only (:mod:`pyautonomousagent.simulation.mission`,
:mod:`pyautonomousagent.bt.leaf`); importing this package registers them and their scenarios.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from pyautonomousagent.missions import (
    crowded,
    drones,
    drones3d,
    gathering,
    patrol,
    radiation_search,
    vacuum,
)
from pyautonomousagent.scenarios import register

__all__ = ["crowded", "drones", "drones3d", "gathering", "patrol", "radiation_search", "vacuum"]

_SCENARIO_FILES = {
    "gathering": "gathering/gathering.yaml",
    "patrol": "patrol/patrol.yaml",
    "x8-patrol": "patrol/x8-patrol.yaml",
    "x8-landing": "patrol/x8-landing.yaml",
    "vacuum": "vacuum/vacuum.yaml",
    "radiation-search": "radiation_search/radiation-search.yaml",
    "gathering-3d": "drones3d/gathering-3d.yaml",
    "patrol-3d": "drones3d/patrol-3d.yaml",
    "crowded": "crowded/crowded.yaml",
    "crowded-avoid": "crowded/crowded-avoid.yaml",
}
for _name, _file in _SCENARIO_FILES.items():
    register(_name, Path(str(resources.files(__name__) / _file)))
