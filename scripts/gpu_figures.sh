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
# budget is left), logging its exit status and time; skipped with under 15 s left, or where
# NAME matches the regular expression GPU_FIGURES_SKIP (e.g. to rerun some steps only).
step() {
  local name=$1 limit=$2 left began rc
  shift 2
  if [[ -n "${GPU_FIGURES_SKIP:-}" && "$name" =~ $GPU_FIGURES_SKIP ]]; then
    echo "=== $name: not taken (GPU_FIGURES_SKIP)"
    return 0
  fi
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
# The host's CPU: with AVX-512 (device hosts often have it; this project's CI machines do not),
# the engines' bits with NumPy's AVX-512 kernels on and off (issue 26's acceptance).
step "host CPU: bits with and without AVX-512" 150 bash -c "grep -m1 'model name' /proc/cpuinfo; \
  grep -o 'avx512[a-z_]*' /proc/cpuinfo | sort -u | tr '\\n' ' '; echo; \
  $PY -m pytest -q -p no:cacheprovider -o addopts='' -rs tests/test_simd_levels.py"
# FMA contraction: a * b + c on the device with numba-cuda's LTO and without (the engine's).
step "a * b + c with and without LTO" 30 $FIG lto
# The same bits first: the device tests (patrol, patrol-3d, gathering with and without
# messages in range, radiation-search, vacuum against the batched engine, 3 seeds each).
XDIST=""
$PY -c "import xdist" 2>/dev/null && XDIST="-n 8"
step "device bit identity (pytest)" 150 $PY -m pytest -q -p no:cacheprovider -o addopts="" -rs \
  $XDIST tests/test_gpu_engine.py -k on_the_device
# Where the bits differ: per recorded column, how many entries and by how many units in the
# last place; and whether the decisions (statuses, behaviours, events) match exactly.
step "device differences per column (seed 1)" 120 $FIG identity 1
BW=${GPU_BANDWIDTH:-$(timeout 60 $FIG bandwidth || echo 3000)}
echo "measured device copy bandwidth: $BW GB/s (bytes read + written, best of 20 copies of 2 GiB)"
$FIG bytes
# The compiled engine's parallel loop compiled first (a cold numba cache: about 30 s), by a
# run of the size the comparisons use, so that they time runs, not the compile.
step "compiled engine's compile (1M x 10)" 60 $PYAA bench patrol --agents 1000000 \
  --iterations 10 --record-every 10 --engines compiled
# Where auto should take the GPU (AUTO_DRONE_ITERATIONS): whole runs in fresh processes,
# the CUDA compile included (on the H100, 2026-11-26: about 9 s; compiled: about 5.7 s at 1M).
step "patrol crossover" 150 bash -c "$FIG crossover 1000 100 1000000 2000000 4000000 \
  | tee $OUT/crossover.txt"
AUTO=$(grep -o 'AUTO_DRONE_ITERATIONS = [0-9]*' "$OUT/crossover.txt" 2>/dev/null | awk '{print $3}')
# Gathering's 4-drone teaching run and patrol around the threshold: what auto picks.
step "auto's choice (AUTO_DRONE_ITERATIONS = ${AUTO:-2000000000})" 45 \
  $FIG auto "${AUTO:-2000000000}"
# Gathering, 1,000,000 drones x 200 iterations, messages in range (a 25 m datalink, every
# drone shares its state every iteration), the swarm spread at constant density (20
# neighbours in range on average); goal: >= 4.7e8 drone-iterations/s, FLAME GPU 2's
# published 1M-agent "circles" rate (spatial messaging, H100 PCIe, 200 steps in 0.428 s).
step "gathering spread 1M x 200, messages in range" 100 $FIG spread gpu 1000000 200 20
# Memory per drone and the largest patrol swarm on the card.
step "memory" 60 $FIG memory 8000000 16000000
# Patrol, 10,000,000 drones x 1000 iterations, record every 100 (goal: >= 1e10 drone-it/s).
step "patrol 10M x 1000 on the GPU" 60 bash -c "$PYAA bench patrol --agents 10000000 \
  --iterations 1000 --record-every 100 --engines gpu --bandwidth $BW --json \
  > $OUT/patrol-10M.json; $FIG rate $OUT/patrol-10M.json $BW"
# 1,000,000 drones: the GPU against the compiled engine on all this machine's cores,
# interleaved: the loops (goal: the GPU's at least 5x faster).
step "patrol 1M x 1000: compiled (all cores) vs gpu" 90 $PYAA bench patrol --agents 1000000 \
  --iterations 1000 --record-every 100 --engines compiled,gpu,compiled,gpu
echo "=== done in $SECONDS s"
