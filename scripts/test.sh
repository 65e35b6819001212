#!/usr/bin/env bash
# Sets up .venv if needed, then runs every test (renderer and background Blender).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$root/scripts/setup.sh"
cd "$root"
.venv/bin/ruff check --quiet .   # lint (pyproject.toml [tool.ruff])
export TFM_REQUIRE_BLENDER=1   # setup.sh installed bpy: Blender tests must run, not be skipped
# Mesa's llvmpipe compiles each shader variant without LLVM's optimisation passes and for 128-bit
# vectors: the tests' small images spend far more time compiling shaders than running them (the
# same images, bit for bit; a GPU ignores both).
export GALLIVM_PERF="${GALLIVM_PERF:-nopt}"
export LP_NATIVE_VECTOR_WIDTH="${LP_NATIVE_VECTOR_WIDTH:-128}"
# Parallel workers, one per core up to 4 (TFM_TEST_WORKERS=0: all in this process); each test file
# runs whole in one worker, so its module fixtures (the quick benchmark's run) are made once.
cores="$(nproc 2>/dev/null || echo 2)"
workers="${TFM_TEST_WORKERS:-$(( cores < 4 ? cores : 4 ))}"
exec .venv/bin/python -m pytest -n "$workers" --dist loadfile "$@"
