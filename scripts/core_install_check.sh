#!/bin/bash
# `pip install .` alone, in a fresh virtual environment (no extra: no numba, no CuPy): the
# gathering scenario runs (batched engine), and the compiled engine says in one line which
# extra it needs (exit 2). Run by .ci/run after the test suite; tests/test_core_install.py
# checks the same by hiding numba from an interpreter that has it.
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-python3}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
"$PYTHON" -m venv "$WORK/venv"
"$WORK/venv/bin/python" -m pip install --quiet --upgrade pip
"$WORK/venv/bin/python" -m pip install --quiet .
if "$WORK/venv/bin/python" -c "import numba" 2>/dev/null; then
  echo "core install check: numba is installed, but no extra was asked for" >&2
  exit 1
fi
"$WORK/venv/bin/pyaa" run gathering --iterations 30 --no-gif --quiet --out "$WORK/gathering"
test -f "$WORK/gathering/states.parquet"
set +e
"$WORK/venv/bin/pyaa" run patrol --engine compiled --iterations 5 --no-gif --quiet \
  --out "$WORK/patrol" 2> "$WORK/err"
rc=$?
set -e
if [[ $rc != 2 || $(wc -l < "$WORK/err") != 1 ]] || ! grep -q "\[fast\]" "$WORK/err"; then
  echo "core install check: --engine compiled without numba: exit $rc, said:" >&2
  cat "$WORK/err" >&2
  exit 1
fi
echo "core install check: pip install . alone runs gathering; --engine compiled names [fast]"
