"""The paper's Fig. 2 example: a vacuum-cleaner robot with a sonar.

Robots (``robot1``, ``robot2``, ...; motion model ``drone2d``) clean a room with obstacles.
Fig. 2's tree (``vacuum.xml``) is a fallback of two sequences: if the sonar sees a wall or an
obstacle closer than ``collision_distance`` (``Condition_Collision``), the robot stops and
turns left or right (``Action_Avoid_Obstacle_S``: side and angle drawn with
:meth:`~pyautonomousagent.bt.Leaf.uniform`, the same on both engines); otherwise it drives
straight ahead on its cruise heading (``Action_Navigate_S``) and vacuums
(``Action_Vacuum_S``).

Written only with the public API (:mod:`pyautonomousagent.mission`,
:mod:`pyautonomousagent.bt`, :mod:`pyautonomousagent.arrays`), and, for the compiled engine,
its documented kernel API (:mod:`pyautonomousagent.kernels`, ``randomness.uniform_of_one``,
``jit.njit``): every leaf has a ``kernel``, and the sensors a compiled form
(:meth:`VacuumMission.compiled_sensors`: the sonar and the stop rule per robot, with the room's
obstacles as arrays; the cleaning grid, shared by all robots, as a sensor of the whole swarm
that cleans the cells in robot order once an iteration), so the compiled engine runs whole
iterations fused (``kernels.py``), and so does the GPU engine (``device.py``: the grid's
steps on the device, the lowest robot row winning a cell by an atomic minimum):

- world objects, parameters, state columns and the blackboard key: as
  :class:`VacuumMission` declares them (the avoid leaf's ``step`` port defaults to the
  motion model's ``turn_step``);
- Phase 2 (:meth:`VacuumMission.sense`): the cells under robots whose brush ran are cleaned
  (:attr:`VacuumMission.grid`, its :meth:`CleaningGrid.coverage`), the sonar is read, and a robot
  whose next step (the drone2d equations) would leave the room or touch an obstacle does not
  move this iteration (it stops; the tree then turns it away). So no robot ever enters an
  obstacle, whatever the tree does;
- marks: the obstacles (grey) and the start positions; in the animation, the area cleaned
  so far (light green cells, :meth:`VacuumMission.frame_marks`), rebuilt from the recorded
  positions and brush states (exact when every iteration is recorded).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from pyautonomousagent.kernels import SensorKernel, SwarmSensorKernel
from pyautonomousagent.mission import (
    Mark,
    Mission,
    Param,
    Reader,
    Recorder,
    ScenarioView,
    SimulationView,
    Swarm,
    World,
    WorldObject,
    check_point_in_world,
    next_position,
    register_mission,
)
from pyautonomousagent.missions.vacuum import leaves
from pyautonomousagent.missions.vacuum.kernels import (
    NOBODY,
    clean_grid,
    count_cleaned,
    sonar_and_stop,
)
from pyautonomousagent.missions.vacuum.room import (
    Circle,
    CleaningGrid,
    Rectangle,
    Room,
    check_inside,
    read_obstacles,
)

__all__ = ["CleaningGrid", "Circle", "Rectangle", "Room", "VacuumMission", "leaves"]

OBSTACLE_COLOUR = "#969696"
"""Grey of the obstacles."""
START_COLOUR = "#31a354"
"""Green of the start positions."""
CLEANED_COLOUR = "#c7e9c0"
"""Light green of the cleaned cells."""
STOP_MARGIN = 1e-6
"""World units kept between a robot's predicted next position and any obstacle or wall, so
that a motion step a rounding error away from the prediction still stays out."""
MAX_CELLS = 4_000_000
"""The largest cleaned-area grid a scenario may ask for (cells)."""


def obstacle_mark(o: Rectangle | Circle) -> Mark:
    """The obstacle ``o`` as a filled grey mark."""
    style: dict[str, Any] = {"colour": OBSTACLE_COLOUR, "fill": True, "legend": "obstacle"}
    if isinstance(o, Rectangle):
        return Mark("rect", o.x, o.y, width=o.width, height=o.height, **style)
    return Mark("circle", o.x, o.y, size=o.radius, **style)


@register_mission
class VacuumMission(Mission):
    """Fig. 2's vacuum-cleaner robots: sonar, stop rule, cleaned-area grid.

    Run state: :attr:`room` (walls and obstacles as arrays) and :attr:`grid` (the cleaned
    cells), made in Phase 1.
    """

    name = "vacuum"
    description = "vacuum-cleaner robots with a sonar clean a room with obstacles (paper Fig. 2)"
    agent_prefix = "robot"
    parameters: ClassVar[tuple[Param, ...]] = (
        Param("robot_speed", 0.2, "world units per iteration",
              "speed Action_Navigate_S requests", minimum=0.0),
        Param("collision_distance", 1.0, "world units",
              "sonar reading below which Condition_Collision succeeds", minimum=0.0),
        Param("sonar_range", 5.0, "world units",
              "farthest the sonar sees; longer distances read as this", minimum=0.0),
        Param("avoid_min_angle", 90.0, "degrees", "smallest turn of Action_Avoid_Obstacle_S",
              minimum=0.0, maximum=360.0),
        Param("avoid_max_angle", 180.0, "degrees", "largest turn of Action_Avoid_Obstacle_S",
              minimum=0.0, maximum=360.0),
        Param("cell_size", 0.5, "world units", "side of a cell of the cleaned-area grid",
              minimum=0.0),
    )  # fmt: skip
    world_objects: ClassVar[tuple[WorldObject, ...]] = (
        WorldObject("obstacles", read_obstacles, (),
                    "obstacles: {shape: rect, x, y, width, height} (lower-left corner) or "
                    "{shape: circle, x, y, radius}, world units, inside the room"),
        WorldObject("start_positions", Reader.points,
                    doc="start positions [x, y], used in turn by robots 1, 2, ... (cycled)"),
    )  # fmt: skip
    columns: ClassVar[dict[str, Any]] = {
        "sonar": np.float64,  # world units, [0, sonar_range]
        "vacuuming": np.int64,  # 1 if the brush ran in this iteration's tick
        "cleaned_cells": np.int64,  # cells this robot cleaned first, cumulative
    }
    meanings: ClassVar[dict[str, tuple[str, str]]] = {
        "sonar": ("world unit", "distance to the nearest wall or obstacle ahead (at most range)"),
        "vacuuming": ("", "1 when the brush ran in this iteration's tick"),
        "cleaned_cells": ("", "free cells this robot cleaned first, cumulative"),
        "cruise_heading": ("degree", "blackboard: the heading the robot cruises on"),
    }

    @classmethod
    def check(cls, scenario: ScenarioView, reader: Reader) -> None:
        """drone2d motion; obstacles and start positions in the room, the starts clear of
        the obstacles; a sonar that sees farther than one step; a turn range and a grid
        that make sense."""
        p = scenario.parameters
        if scenario.model != "drone2d":
            raise reader.fail("model", "drone2d (the stop rule predicts its next step)",
                              scenario.model)  # fmt: skip
        if p.sonar_range <= 0.0:
            raise reader.fail("parameters.sonar_range", "a number > 0", p.sonar_range)
        if not p.robot_speed < p.collision_distance <= p.sonar_range:
            raise reader.fail(
                "parameters.collision_distance",
                f"a number > robot_speed ({p.robot_speed:g}) and <= sonar_range "
                f"({p.sonar_range:g}), so the sonar sees an obstacle before the next step",
                p.collision_distance,
            )
        if p.avoid_min_angle > p.avoid_max_angle:
            raise reader.fail(
                "parameters.avoid_min_angle",
                f"<= avoid_max_angle ({p.avoid_max_angle:g})",
                p.avoid_min_angle,
            )
        width, height = scenario.world
        cells = np.ceil(width / p.cell_size) * np.ceil(height / p.cell_size) if p.cell_size else 0
        if not 0 < cells <= MAX_CELLS:
            raise reader.fail(
                "parameters.cell_size",
                f"a number > 0 giving at most {MAX_CELLS} cells",
                p.cell_size,
            )
        check_inside(reader, scenario.objects.obstacles, scenario.world, "world.obstacles")
        room = Room(width, height, scenario.objects.obstacles)
        for i, point in enumerate(scenario.objects.start_positions):
            where = f"world.start_positions[{i}]"
            check_point_in_world(reader, scenario, point, where)
            if room.blocked(np.array([point[0]]), np.array([point[1]]), STOP_MARGIN)[0]:
                raise reader.fail(where, "a point clear of every obstacle", list(point))

    def blackboard(self) -> dict[str, Any]:
        """``cruise_heading``: the heading Action_Navigate_S holds (degrees)."""
        return {"cruise_heading": np.float64}

    def place(self, swarm: Swarm, world: World, rng: np.random.Generator) -> None:
        """Robots on their start positions, headings rounded to whole degrees (so turns of
        whole turn steps land exactly), cruising on them, with a first sonar reading; the room
        and an uncleaned grid."""
        self.room = Room(world.width, world.height, self.scenario.objects.obstacles)
        self.grid = CleaningGrid(self.room, self.params.cell_size)
        points = self.scenario.objects.start_positions
        start = np.asarray([points[i % len(points)] for i in range(swarm.size)], dtype=np.float64)
        s = swarm.columns
        s["x"][:], s["y"][:] = start[:, 0], start[:, 1]
        s["heading"][:] = np.round(s["heading"]) % 360.0
        swarm.blackboard["cruise_heading"][:] = s["heading"]
        s["sonar"][:] = self.room.sonar(s["x"], s["y"], s["heading"], self.params.sonar_range)
        self.fresh = np.zeros(swarm.size, dtype=np.int64)  # the compiled grid's, per robot
        self.winner = np.full(self.grid.free.size, NOBODY)  # the GPU's, per cell

    def sense(self, sim: SimulationView) -> np.ndarray:
        """Clean under the brushes that ran, read the sonar, stop robots about to collide.

        Returns:
            The robots whose next step stays in the room and clear of every obstacle.
        """
        s = sim.swarm.columns
        s["cleaned_cells"] += self.grid.clean(s["x"], s["y"], s["vacuuming"] == 1)
        s["vacuuming"][:] = 0
        s["sonar"][:] = self.room.sonar(s["x"], s["y"], s["heading"], self.params.sonar_range)
        next_x, next_y = next_position(s["x"], s["y"], s["speed"], s["heading"])
        return ~self.room.blocked(next_x, next_y, STOP_MARGIN)

    def compiled_sensors(self, sim: SimulationView) -> SensorKernel:
        """:meth:`sense` compiled: the sonar and the stop rule per robot
        (``kernels.sonar_and_stop``, the room's rectangles and circles as its state), and the
        cleaning as a sensor of the whole swarm (``kernels.clean_grid`` once an iteration on
        :attr:`grid`'s arrays, then ``kernels.count_cleaned`` per robot; on the GPU
        ``device.claim_cell`` and ``device.take_cell``)."""
        # imports numba.cuda: here, where only the compiled and GPU engines (numba) call it
        from pyautonomousagent.missions.vacuum.device import claim_cell, take_cell

        room, grid = self.room, self.grid
        swarm = SwarmSensorKernel(
            clean_grid, count_cleaned, ("x", "y", "vacuuming", "cleaned_cells"),
            (grid.free, grid.cleaned, self.fresh, self.winner), (float(grid.cell),),
            device=(claim_cell, take_cell),
        )  # fmt: skip
        return SensorKernel(
            sonar_and_stop, ("x", "y", "speed", "heading", "sonar"),
            (float(room.width), float(room.height), float(self.params.sonar_range), STOP_MARGIN),
            swarm=swarm, state=(room.rects, room.circles),
        )  # fmt: skip

    def frame_marks(self, recorder: Recorder, row: int) -> list[Mark]:
        """The cells cleaned before record ``row``: a cell is cleaned in Phase 2 under a robot
        whose brush ran in the tick before, i.e. at a recorded position with ``vacuuming``."""
        grid = self._replayed_grid(recorder, row)
        cell = grid.cell
        rows, cols = np.nonzero(grid.cleaned)
        return [
            Mark("rect", c * cell, r * cell, width=cell, height=cell, colour=CLEANED_COLOUR,
                 fill=True, legend="cleaned area")
            for r, c in zip(rows.tolist(), cols.tolist(), strict=True)
        ]  # fmt: skip

    def _replayed_grid(self, recorder: Recorder, row: int) -> CleaningGrid:
        """The cleaning grid replayed from the records up to ``row`` (incrementally, as the
        animation asks for rows in order)."""
        done = getattr(self, "_replayed_to", None)
        if done is None or done > row:
            room = Room(*self.scenario.world, self.scenario.objects.obstacles)
            self._replay = CleaningGrid(room, self.params.cell_size)
            done = 0
        c = recorder.columns
        for r in range(done, row):
            self._replay.clean(c["x"][r], c["y"][r], c["vacuuming"][r] == 1)
        self._replayed_to = row
        return self._replay

    def marks(self) -> list[Mark]:
        """The obstacles (grey) and the start positions (green squares)."""
        marks = [obstacle_mark(o) for o in self.scenario.objects.obstacles]
        for i, (x, y) in enumerate(dict.fromkeys(self.scenario.objects.start_positions), 1):
            marks.append(Mark("point", x, y, f"D{i}", colour=START_COLOUR, symbol="s",
                              legend="start position"))  # fmt: skip
        return marks
