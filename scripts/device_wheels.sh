#!/bin/bash
# Wheels for a GPU machine without registry access (such as the project's lent H100/H200,
# which ship numba, numba-cuda, CuPy for CUDA 13, NumPy, pyarrow, matplotlib and PyYAML):
# the dependencies such a machine lacks (py_trees and pydot) in .whl/, and NumPy 2.4: the lent
# machines' image (seen 2026-11-26) pairs numba-cuda 0.30.4 with NumPy 2.5.2, which dropped
# np.row_stack, so numba-cuda fails to compile any kernel there (AttributeError).
# Run here, from the repository's root; then on the GPU machine, from a copy of the
# repository holding .whl/ (the project itself runs from src/):
#   python3 -m pip install -q --no-index --no-deps --target /tmp/site .whl/*.whl
#   PYTHONPATH=$PWD/src:/tmp/site bash scripts/gpu_figures.sh
set -e
DEST=${1:-.whl}
PYTHON=${PYTHON:-python3}
VERSION=${DEVICE_PYTHON:-3.12}
mkdir -p "$DEST"
"$PYTHON" -m pip download -q --no-deps --only-binary=:all: --python-version "$VERSION" \
    --implementation cp --platform manylinux2014_x86_64 -d "$DEST" \
    "py_trees==2.6.0" "pydot==4.0.1"
"$PYTHON" -m pip download -q --no-deps --only-binary=:all: --python-version "$VERSION" \
    --implementation cp --platform manylinux_2_28_x86_64 -d "$DEST" "numpy==2.4.6"
ls "$DEST"
