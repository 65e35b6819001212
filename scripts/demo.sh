#!/usr/bin/env bash
# Sets up .venv if needed, then renders the built-in demo scene with the add-on through Blender.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$root/scripts/setup.sh"
cd "$root"
exec .venv/bin/python scripts/demo.py --out "${1:-out}"
