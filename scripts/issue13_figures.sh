#!/bin/bash
# Issue 13's figures, side by side (docs/performance.md, "Issue 13's goals: where they stand").
# Run from anywhere with the project's pyaa on PATH (e.g. after `make test`, .venv/bin).
set -x
export PYAA_CACHE_DIR=${PYAA_CACHE_DIR:-/tmp/pyaa_cache}
# Warm numba's cache first (compiling is set-up, not loop; not measured here).
pyaa bench patrol --agents 1000 --iterations 4000 --engines compiled > /dev/null
pyaa bench patrol --agents 1000000 --iterations 20 --record-every 20 --engines compiled > /dev/null
pyaa bench x8-patrol --agents 1 --iterations 50 --engines compiled,batched > /dev/null
pyaa bench gathering --engines compiled > /dev/null  # from here on, auto takes compiled for it
pyaa bench gathering --engines pytrees,batched,compiled,auto,pytrees,batched,compiled,auto
pyaa bench patrol --agents 1000 --iterations 4000 --engines pytrees,batched,compiled,batched,compiled --reference-iterations 200
pyaa bench patrol --agents 1000000 --iterations 20 --record-every 20 --engines batched,compiled,batched,compiled
pyaa bench patrol --agents 1000000 --iterations 200 --record-every 200 --engines batched,compiled,batched,compiled
pyaa bench x8-patrol --agents 1,10 --engines pyfly,batched,compiled,batched,compiled --reference-iterations 400
pyaa bench x8-patrol --agents 100 --engines batched,compiled,batched,compiled
pyaa bench patrol --agents 10000 --iterations 1000 --engines batched,batched,batched --save --json
pyaa bench patrol --stress --engines batched --stress-start 20000000 --stress-iterations 5
