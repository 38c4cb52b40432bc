#!/bin/bash
# Issue 27's figures on a GPU machine (docs/performance.md, "GPU engine"): one script, its
# steps in order of importance, each under a time limit and all within GPU_FIGURES_BUDGET
# seconds (default 480), so that it can be run again inside one device lease. A step that
# fails or runs out of time is logged as such and the next one runs; a step there is no time
# left for is logged as "not taken". Everything it prints also goes to $OUT/gpu_figures.log.
#
# Run from the repository's root with the project importable (pip install '.[gpu]', or
# PYTHONPATH=src with numba-cuda, CuPy, py_trees and pydot installed). On a machine without
# a usable GPU it stops at once (exit 2). A lent GPU machine without registry access:
# scripts/device_wheels.sh here, then there (the wheels in .whl/):
#   python3 -m pip install -q --no-index --no-deps --target /tmp/site .whl/*.whl
#   PYTHONPATH=$PWD/src:/tmp/site bash scripts/gpu_figures.sh
set -u
export PYAA_CACHE_DIR=${PYAA_CACHE_DIR:-/tmp/pyaa_cache} PYTHONUNBUFFERED=1
HERE=$(cd "$(dirname "$0")" && pwd)
OUT=${OUT:-$(mktemp -d)}
BUDGET=${GPU_FIGURES_BUDGET:-480}
PY=${PYTHON:-python3}
FIG="$PY $HERE/gpu_figures.py"
PYAA="$PY -m pyautonomousagent.cli"
exec > >(tee -a "$OUT/gpu_figures.log") 2>&1

# step NAME SECONDS COMMAND...: run COMMAND under a limit of SECONDS (less where less of the
# budget is left), logging its exit status and time; skipped with under 15 s left.
step() {
  local name=$1 limit=$2 left began rc
  shift 2
  left=$((BUDGET - SECONDS))
  if ((left < 15)); then
    echo "=== $name: not taken (out of time: ${left} s of the ${BUDGET} s budget left)"
    return 0
  fi
  ((limit > left)) && limit=$left
  echo "=== $name (limit ${limit} s, $((SECONDS)) s into the run)"
  began=$SECONDS
  timeout --kill-after=5 "$limit" "$@"
  rc=$?
  if ((rc == 124 || rc == 137)); then
    echo "=== $name: TIMED OUT after $((SECONDS - began)) s"
  else
    echo "=== $name: exit $rc after $((SECONDS - began)) s"
  fi
  return 0
}

$FIG check || exit 2
step "device and versions" 30 bash -c "nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv; nproc; $FIG device"
# The same bits first: the device tests (patrol, patrol-3d, gathering with and without
# messages in range, radiation-search, vacuum against the batched engine, 3 seeds each).
XDIST=""
$PY -c "import xdist" 2>/dev/null && XDIST="-n 8"
step "device bit identity (pytest)" 200 $PY -m pytest -q -p no:cacheprovider -o addopts="" -rs \
  $XDIST tests/test_gpu_engine.py -k on_the_device
BW=${GPU_BANDWIDTH:-$(timeout 60 $FIG bandwidth || echo 3000)}
echo "measured device copy bandwidth: $BW GB/s (bytes read + written, best of 20 copies of 2 GiB)"
$FIG bytes
# Patrol, 10,000,000 drones x 1000 iterations, record every 100 (goal: >= 1e10 drone-it/s).
step "patrol 10M x 1000 on the GPU" 120 bash -c "$PYAA bench patrol --agents 10000000 \
  --iterations 1000 --record-every 100 --engines gpu,gpu --bandwidth $BW --json \
  > $OUT/patrol-10M.json; $FIG rate $OUT/patrol-10M.json $BW"
# Gathering, 1,000,000 drones x 200 iterations with messages in range (a 25 m datalink; the
# gathering order at iteration 100); goal: >= 4.7e8 drone-iterations/s. (On the H100,
# 2026-11-26, it did not finish in 90 s: gathering's 4 slots and 4 surveillance points pack
# the swarm, so every drone hears about a quarter of it and the shared-data pair table is
# N x N/4. A fair spatial-messaging figure needs a swarm spread at constant density.)
step "gathering 1M x 200, messages in range" 90 bash -c "$PYAA bench gathering \
  --agents 1000000 --iterations 200 --record-every 100 --engines gpu,gpu --bandwidth $BW \
  --compare 'in-range:datalink_range=25,gathering_iteration=100' --json \
  > $OUT/gathering-1M.json; $FIG rate $OUT/gathering-1M.json $BW"
# 1,000,000 drones: the GPU against the compiled engine on all this machine's cores
# (its parallel loop compiled first, by a run of the same size), interleaved.
step "compiled engine's compile (1M x 10)" 120 $PYAA bench patrol --agents 1000000 \
  --iterations 10 --record-every 10 --engines compiled
step "patrol 1M x 1000: compiled (all cores) vs gpu" 100 $PYAA bench patrol --agents 1000000 \
  --iterations 1000 --record-every 100 --engines compiled,gpu,compiled,gpu
# Where auto should take the GPU (AUTO_DRONE_ITERATIONS).
step "patrol crossover" 120 $FIG crossover 1000 100 1000000
# Memory per drone and the largest patrol swarm on the card.
step "memory" 90 $FIG memory 8000000 16000000
# Gathering's 4-drone teaching run: auto keeps it off the GPU.
step "gathering teaching run on auto" 60 bash -c "$PYAA run gathering --engine auto --no-gif \
  --quiet --out /tmp/gathering-auto --overwrite && grep -o '\"engine\": \"[a-z]*\"' \
  /tmp/gathering-auto/run.json | head -1"
echo "=== done in $SECONDS s"
