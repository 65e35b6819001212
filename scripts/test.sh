#!/usr/bin/env bash
# Sets up .venv if needed, then runs every test (renderer and background Blender).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$root/scripts/setup.sh"
cd "$root"
.venv/bin/ruff check --quiet .   # lint (pyproject.toml [tool.ruff])
export TFM_REQUIRE_BLENDER=1   # setup.sh installed bpy: Blender tests must run, not be skipped
exec .venv/bin/python -m pytest "$@"
