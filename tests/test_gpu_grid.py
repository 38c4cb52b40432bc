"""The GPU engine's datalink grid (issue 20): messages grouped by cell on the device, each
receiver's cells merged by message index. Run through numba's CUDA simulator: the pairs
found equal the CPU datalink's (``Datalink.deliver``), in the same order per receiver, with
points on cell borders and at exactly the range; a 40-drone gathering spread over many
cells gives the batched engine's bits. The grid's geometry on the CPU."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap

import pytest

from pyautonomousagent import jit

needs_numba = pytest.mark.skipif(not jit.available(), reason="numba missing or PYAA_NO_JIT set")


def _simulate(script: str) -> list[str]:
    """``script``'s printed lines, run under ``NUMBA_ENABLE_CUDASIM=1``; its last is "same"."""
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    done = subprocess.run(
        [sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stdout + done.stderr
    lines = done.stdout.strip().splitlines()
    assert lines[-1] == "same", done.stdout
    return lines


@needs_numba
def test_the_geometry_keeps_cells_at_least_the_range_and_bounds_their_number() -> None:
    from pyautonomousagent.engines.gpu_grid import AXIS, MARGIN, ONE_CELL, geometry

    low_x, low_y, side, along_x, along_y = geometry((0.0, 17.5, -1.0, 9.0), 2.5, 80)
    assert (low_x, low_y, side) == (0.0, -1.0, 2.5 * (1.0 + MARGIN))
    assert (along_x, along_y) == (7, 4)
    *_, side, along_x, along_y = geometry((0.0, 17.5, -1.0, 9.0), 2.5, 12)  # 28 > 12
    assert side == 2.0 * 2.5 * (1.0 + MARGIN) and (along_x, along_y) == (4, 2)
    *_, side, along_x, along_y = geometry((0.0, 1e12, 0.0, 1.0), 1.0, 10**9)
    assert along_x <= AXIS and side >= 1e12 / AXIS
    assert geometry((0.0, math.nan, 0.0, 1.0), 1.0, 80) == ONE_CELL
    assert geometry((0.0, 1.0, 0.0, 1.0), 0.0, 80) == ONE_CELL


#: Under the simulator: layouts of 40 agents (receivers at x, y; their messages sent from
#: sx, sy), grouped on a DeviceGrid and walked by each receiver as the generated
#: ``handle_near`` walks them; prints the first layout whose pairs (per receiver, in order)
#: differ from the CPU datalink's, or per layout the cells with messages, the pairs in range
#: and the candidates out of range, then "same".
PAIRS = textwrap.dedent(
    """
    import numpy as np
    from numba import cuda, int64
    from pyautonomousagent.datalink import Datalink
    from pyautonomousagent.engines import gpu_grid
    from pyautonomousagent.kernels import hypot

    spans_of, next_of = gpu_grid.cell_spans.py_func, gpu_grid.next_message.py_func
    gpu_grid.cell_of = gpu_grid.cell_of.py_func  # (called by cell_spans' Python body)
    REACH, N = 2.5, 40

    @cuda.jit
    def walk(rx, ry, sx, sy, reach, grid, starts, order, found, counts):
        a = cuda.grid(1)
        if a >= rx.shape[0]:
            return
        heads = cuda.local.array(9, int64)
        ends = cuda.local.array(9, int64)
        spans = spans_of(rx[a], ry[a], grid, starts, heads, ends)
        m = next_of(heads, ends, spans, order)
        while m >= 0:
            if m != a and hypot(rx[a] - sx[m], ry[a] - sy[m]) <= reach:
                found[a, counts[a, 0]] = m
                counts[a, 0] += 1
            elif m != a:
                counts[a, 1] += 1  # a candidate out of range
            m = next_of(heads, ends, spans, order)

    def crafted(rng):
        side = REACH * (1.0 + gpu_grid.MARGIN)
        border = lambda: rng.integers(1, 6, 2) * side  # a point on cell borders
        x, y = rng.integers(0, 36, (2, N)) * 0.5  # a lattice of 0.5: exact distances
        sx, sy = rng.integers(0, 36, (2, N)) * 0.5
        x[:2], y[:2], sx[:2], sy[:2] = (0.0, 17.5), (0.0, 17.5), (0.0, 17.5), (0.0, 17.5)
        steps = [(2.5, 0.0), (0.0, -2.5), (-1.5, 2.0), (2.0, 1.5), (-2.5, 0.0)]  # 2.5 exactly
        for i in range(2, N, 2):
            if i % 4 == 2:
                sx[i], sy[i] = border()
                x[i], y[i] = border()
            dx, dy = steps[i % len(steps)]
            x[i + 1], y[i + 1] = sx[i] + dx, sy[i] + dy  # receiver i + 1 at range of i
            if i % 8 == 0:
                x[i + 1] = np.nextafter(x[i + 1], x[i + 1] + dx)  # just beyond range
        return [np.clip(v, 0.0, 17.5) for v in (x, y, sx, sy)]

    def scattered(rng):
        x, y, sx, sy = np.round(rng.uniform(0.0, 17.5, (4, N)) * 4.0) / 4.0
        return x, y, sx, sy

    layouts = [crafted(np.random.default_rng(s)) for s in range(3)]
    layouts += [scattered(np.random.default_rng(10 + s)) for s in range(2)]
    grid = gpu_grid.DeviceGrid(N)
    for number, (x, y, sx, sy) in enumerate(layouts):
        link = Datalink(REACH)
        link.send(np.arange(N), "t", {"v": np.zeros(N)}, (sx, sy))
        (delivery,) = link.deliver(x, y)
        assert not delivery.to_all
        expected = [[] for _ in range(N)]
        for r, m in zip(delivery.receivers.tolist(), delivery.rows.tolist()):
            expected[r].append(m)
        dsx, dsy = cuda.to_device(sx), cuda.to_device(sy)
        box = (min(x.min(), sx.min()), max(x.max(), sx.max()),
               min(y.min(), sy.min()), max(y.max(), sy.max()))
        grid.group(dsx, dsy, N, tuple(map(float, box)), REACH)
        found = cuda.to_device(np.full((N, N), -1, dtype=np.int64))
        counts = cuda.to_device(np.zeros((N, 2), dtype=np.int64))
        walk[1, N](cuda.to_device(x), cuda.to_device(y), dsx, dsy, REACH, *grid.arguments(),
                   found, counts)
        found, counts = found.copy_to_host(), counts.copy_to_host()
        got = [found[r, : counts[r, 0]].tolist() for r in range(N)]
        if got != expected:
            print("differ", number, [(r, got[r], expected[r])
                                     for r in range(N) if got[r] != expected[r]][:3])
            raise SystemExit(1)
        starts = grid.starts.copy_to_host()[: grid.cells + 1]
        side = grid.grid.copy_to_host()[2]
        print("layout", number, int((np.diff(starts) > 0).sum()), int(counts[:, 0].sum()),
              int(counts[:, 1].sum()), int(side == REACH * (1.0 + gpu_grid.MARGIN)))
    print("same")
    """
)


@needs_numba
def test_the_device_grid_finds_the_cpu_datalinks_pairs_in_order() -> None:
    """40 receivers and messages over 7 x 7 cells 2.5 wide (5 layouts: crafted ones with
    messages on cell borders and receivers at exactly the range or just beyond it, and
    scattered ones on a 0.25 lattice): each receiver's pairs and their order equal
    ``Datalink.deliver``'s."""
    lines = _simulate(PAIRS)
    layouts = [list(map(int, line.split()[2:])) for line in lines if line.startswith("layout")]
    assert len(layouts) == 5
    for cells, pairs, outside, unwidened in layouts:
        assert cells > 10 and pairs > 10 and outside > 0  # many cells, some candidates far
        assert unwidened == 1  # cells one range (plus the margin) wide: borders as crafted


#: Under the simulator: gathering with 40 drones spread over the world (one refuelling
#: place each, 11 units apart) and a 12-unit range, batched against gpu; raises at the first
#: difference, else prints the cells with messages of each grouping, the pairs heard and "same".
SPREAD = textwrap.dedent(
    """
    import numpy as np
    from pyautonomousagent import Simulation, load
    from pyautonomousagent.engines import gpu_grid
    from pyautonomousagent.testing import check_same_runs

    cells = []
    group = gpu_grid.DeviceGrid.group
    def counted(self, *arguments):
        group(self, *arguments)
        starts = self.starts.copy_to_host()[: self.cells + 1]
        cells.append(int((np.diff(starts) > 0).sum()))
    gpu_grid.DeviceGrid.group = counted

    rng = np.random.default_rng(5)
    places = [[10.0 + 11.0 * (i % 8) + rng.uniform(-2, 2), 20.0 + 11.0 * (i // 8)]
              for i in range(40)]
    scenario = load("gathering").with_overrides(
        agents=40, iterations=12, gathering_iteration=5, datalink_range=12.0,
        refueling_positions=places)
    a, b = (Simulation.create(scenario, seed=1, engine=e).run(progress=False)
            for e in ("batched", "gpu"))
    check_same_runs(a, b, ("batched", "gpu"))  # records, traces, behaviour, events
    sa, sb = a.mission.shared, b.mission.shared
    if any(sa[r] != sb[r] for r in range(len(sa))):
        print("differ shared data")
        raise SystemExit(1)
    print("cells", *cells)
    print("pairs", sa._pair_keys.size, int((sa._everyone_iteration > 0).sum()))
    print("same")
    """
)


@needs_numba
def test_a_swarm_over_many_cells_gives_the_batched_engines_bits() -> None:
    """40 drones x 12 iterations, each hearing only its lattice neighbours: the shared data
    (grouped every iteration over more than 10 cells) and the gathering order (one message)
    handled per receiver on the device's grid equal the batched engine's."""
    lines = _simulate(SPREAD)
    (cells,) = [list(map(int, line.split()[1:])) for line in lines if line.startswith("cells")]
    (pairs,) = [list(map(int, line.split()[1:])) for line in lines if line.startswith("pairs")]
    shared = [c for c in cells if c > 1]  # the shared data, over many cells
    assert len(shared) >= 10 and min(shared) > 10 and cells.count(1) == 1  # and the order
    heard, everyone = pairs
    assert everyone == 0 and 40 <= heard < 40 * 39 // 4  # neighbours heard, far ones not
