#!/usr/bin/env bash
# Sets up .venv if needed, then runs every test (renderer and background Blender).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$root/scripts/setup.sh"
cd "$root"
exec .venv/bin/python -m pytest "$@"
