#!/usr/bin/env bash
# Creates .venv (Python 3.11) with the project, Blender (bpy 5.0.1) and the test tools.
# Idempotent: a second run only checks. Source it or run it; PY overrides the interpreter.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
find_python() {
    for p in "${PY:-}" python3.11 python3; do
        [ -n "$p" ] || continue
        if command -v "$p" >/dev/null 2>&1 && "$p" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
            echo "$p"; return 0
        fi
    done
    echo "Python 3.11 is required (bpy 5.0.1 is built for it); set PY=/path/to/python3.11" >&2
    return 1
}
stamp=".venv/.installed-$(sha1sum pyproject.toml | cut -c1-12)"
if [ ! -f "$stamp" ]; then
    py="$(find_python)"
    [ -x .venv/bin/python ] || "$py" -m venv .venv
    .venv/bin/python -m pip install -q --upgrade pip
    .venv/bin/python -m pip install -q -e ".[blender,test]"
    rm -f .venv/.installed-*
    touch "$stamp"
fi
