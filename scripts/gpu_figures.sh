#!/bin/bash
# Issue 20's figures on a GPU machine (docs/performance.md, "GPU engine (in progress)").
# Run from anywhere with the project's pyaa and python on PATH, numba-cuda and CuPy installed
# (pip install '.[gpu]'). On a machine without a usable GPU it stops at once (exit 2).
set -e
export PYAA_CACHE_DIR=${PYAA_CACHE_DIR:-/tmp/pyaa_cache}
HERE=$(cd "$(dirname "$0")" && pwd)
OUT=${OUT:-$(mktemp -d)}
python "$HERE/gpu_figures.py" check || exit 2
set -x
python "$HERE/gpu_figures.py" device
# The same bits first: the device tests (patrol, patrol-3d, gathering, radiation-search, vacuum
# against the batched engine, 3 seeds each), where the tests are beside this script.
if [ -d "$HERE/../tests" ]; then
  (cd "$HERE/.." && python -m pytest -q -p no:cacheprovider -o addopts="" -rs \
     tests/test_gpu_engine.py -k on_the_device)
fi
BW=$(python "$HERE/gpu_figures.py" bandwidth)
echo "measured device copy bandwidth: $BW GB/s (bytes read + written, best of 20 copies of 2 GiB)"
python "$HERE/gpu_figures.py" bytes
# Warm numba's caches (compiling is set-up, reported apart).
pyaa bench patrol --agents 1000 --iterations 10 --engines gpu,compiled > /dev/null
pyaa bench gathering --engines compiled > /dev/null  # from here on, auto takes compiled for it
# Patrol, 10,000,000 drones x 1000 iterations, record every 100 (goal: loop >= 1e10/s).
pyaa bench patrol --agents 10000000 --iterations 1000 --record-every 100 --engines gpu,gpu --bandwidth "$BW" --json > "$OUT/patrol-10M.json"
python "$HERE/gpu_figures.py" rate "$OUT/patrol-10M.json" "$BW"
# 100,000,000 drones on the card (memory per drone).
python "$HERE/gpu_figures.py" memory 100000000
# 1,000,000 drones: the GPU against the compiled engine on all this machine's cores, and on 2.
pyaa bench patrol --agents 1000000 --iterations 1000 --record-every 100 --engines compiled,gpu,compiled,gpu
NUMBA_NUM_THREADS=2 taskset -c 0,1 pyaa bench patrol --agents 1000000 --iterations 1000 --record-every 100 --engines compiled,compiled
# Where auto should take the GPU: the smallest patrol swarm (x 1000 iterations, record every
# 100) whose whole run is faster on the GPU than on the compiled engine (all cores).
python "$HERE/gpu_figures.py" crossover 1000 100 3
# Gathering's 4-drone teaching run: auto must be no slower than the CPU engines (it keeps it off the GPU).
pyaa bench gathering --engines batched,compiled,auto,batched,compiled,auto
