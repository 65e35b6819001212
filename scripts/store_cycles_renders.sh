#!/usr/bin/env bash
# Renders with Cycles the scenes the Blender tests compare TFM against and stores the images in
# tests/data/cycles/, named by what Cycles reads (tests/blender/blender_helpers.cycles_key); the
# tests then read them instead of rendering Cycles again. A test whose scene has no stored image
# fails and names this command: run it after changing a compared scene (or Blender's version).
# Arguments go to pytest (e.g. a test file: only its images are made; the others are kept).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
if [ "$#" -eq 0 ]; then
    rm -rf tests/data/cycles      # every image made again: none left from scenes no test renders
    set -- tests/blender
fi
TFM_STORE_CYCLES=1 TFM_REQUIRE_BLENDER=1 exec .venv/bin/python -m pytest -q "$@"
