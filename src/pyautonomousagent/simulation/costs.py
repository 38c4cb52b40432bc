"""What a run costs on each engine, estimated before it is built: seconds and bytes.

``Simulation.create(engine="auto")`` compares the batched and the compiled engine on the run
it is given (the swarm, the iterations, the record rate; whether the compiled loop is in
numba's cache already) with :func:`run_costs`, then takes the faster of those whose memory
fits (:func:`pick_engine`). The figures are measured on this project's 2-core machine
(patrol; docs/performance.md, "How auto chooses"); they rank the engines, they do not
promise a time.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from pyautonomousagent.record_blocks import RECORD_BLOCK_BYTES

#: Seconds of batched loop from which "auto" compiles: compiling a tree's fused loop takes
#: about a minute the first time (patrol's 66 s, gathering's 76 s), then well under 1 s from
#: numba's cache. It is the cost :func:`run_costs` gives a compile not in the cache yet.
AUTO_COMPILE_SECONDS = 70.0
#: Loop costs per iteration and per agent-iteration, in seconds: the batched engine's
#: (NumPy's fixed cost of about 250 calls; patrol's drones) and the compiled engine's (its call
#: of 500 iterations spread over them; patrol's drones).
BATCHED_PER_ITERATION = 1.5e-4
BATCHED_PER_AGENT = 6.5e-8
COMPILED_PER_ITERATION = 2e-6
COMPILED_PER_AGENT = 1.1e-8
#: Seconds to load a compiled loop from numba's cache (set-up).
COMPILED_LOAD_SECONDS = 1.0
#: Seconds per agent and record on either engine: storing a record.
RECORD_PER_AGENT = 6e-8
#: Peak bytes of a run beyond its records: the process (Python, NumPy, pyarrow; the compiled
#: engine's numba code and threads besides) and per agent (its state, NumPy's temporaries).
BATCHED_BYTES = 150 * 2**20
COMPILED_BYTES = BATCHED_BYTES + 66 * 2**20
BYTES_PER_AGENT = 260
#: "auto" never takes an engine that needs more memory than the one that needs the least by
#: more than this factor or :data:`MEMORY_SLACK` bytes, whichever allows more.
MEMORY_MARGIN = 1.2
MEMORY_SLACK = 256 * 2**20


@dataclass(frozen=True)
class RunCost:
    """An engine's estimated cost of one run: ``seconds`` (set-up's compile and the loop)
    and peak ``bytes`` of memory (the records and the engine's working memory)."""

    seconds: float
    bytes: int


def batched_seconds(agents: int, iterations: int) -> float:
    """About how long the batched engine's loop takes for a run, in seconds."""
    return iterations * (BATCHED_PER_ITERATION + agents * BATCHED_PER_AGENT)


def run_costs(
    agents: int,
    iterations: int,
    record_every: int = 1,
    columns: int = 21,
    compiled_ready: bool = False,
) -> dict[str, RunCost]:
    """The batched and the compiled engine's estimated costs of a run of ``agents`` x
    ``iterations``, recording every ``record_every``-th iteration of ``columns`` columns;
    the compiled engine pays :data:`AUTO_COMPILE_SECONDS` unless ``compiled_ready`` (its
    loop is in numba's cache). Both store the same records (at most 8 bytes per column,
    agent and record)."""
    records = iterations // record_every + 1
    row = agents * (columns * 8 + 2)  # the columns and the active behaviour
    recorded = records * row
    storing = records * agents * RECORD_PER_AGENT
    compile_s = COMPILED_LOAD_SECONDS if compiled_ready else AUTO_COMPILE_SECONDS
    compiled = iterations * (COMPILED_PER_ITERATION + agents * COMPILED_PER_AGENT)
    block = min(recorded, max(RECORD_BLOCK_BYTES, row))
    return {
        "batched": RunCost(
            batched_seconds(agents, iterations) + storing,
            BATCHED_BYTES + agents * BYTES_PER_AGENT + recorded,
        ),
        "compiled": RunCost(
            compile_s + compiled + storing,
            COMPILED_BYTES + agents * BYTES_PER_AGENT + recorded + block,
        ),
    }


def pick_engine(costs: Mapping[str, RunCost], available: int | None = None) -> str:
    """The engine of ``costs`` that takes the least seconds among those whose bytes fit in
    ``available`` (None: any) and are within :data:`MEMORY_MARGIN` (or :data:`MEMORY_SLACK`)
    of the least bytes of those; where none fits, the one that needs the least memory. A
    tie goes to the first given (list the engine that needs no compiling first)."""
    engines = list(costs)
    fitting = [e for e in engines if available is None or costs[e].bytes <= available]
    if not fitting:
        return min(engines, key=lambda e: costs[e].bytes)
    least = min(costs[e].bytes for e in fitting)
    bound = max(MEMORY_MARGIN * least, least + MEMORY_SLACK)
    allowed = [e for e in fitting if costs[e].bytes <= bound]
    return min(allowed, key=lambda e: costs[e].seconds)
