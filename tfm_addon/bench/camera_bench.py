"""The cost of the camera's depth of field and motion blur and of a fire lighting the ground, as
ratios to the same frame without them, measured side by side in one run (docs/benchmark.md).

Every frame is a final render of ``SAMPLES`` antialiasing samples (render_samples, AUTO quality)
with warm caches: depth of field and camera motion change only the view (a G-buffer and the
light passes per sample); a moving medium moves its maps, rebuilt for each sample; the fire's
light is computed once per medium (engine/fire_light.py) and costs its points in the first pass.
``python -m tfm_addon.bench.camera_bench [--quick]``
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..engine import Renderer, RenderSettings
from ..engine import fire_light as fire_light_module
from ..engine.camera_effects import Motion, ObjectMotion
from ..engine.fire_light import fire_light
from ..engine.sampling import render_samples
from ..engine.scene import Aperture
from ..scenes import fire_scene, smoke_scene
from .timing import time_side_by_side

SAMPLES = 16


def _shifted(dx: float) -> np.ndarray:
    m = np.eye(4)
    m[0, 3] = dx
    return m


def cases(width: int, height: int, grid: int) -> dict:
    smoke = smoke_scene(width=width, height=height, n=grid)
    cam = smoke.camera
    focus = float(np.linalg.norm(cam.position - np.array([0.0, 0.0, 1.2]))) - 3.0
    medium = smoke.media[0]
    moving = ObjectMotion((_shifted(-0.4), np.eye(4), _shifted(0.4)), np.eye(4))
    fire = fire_scene(width, height, grid // 2, kind="FIRE", with_ground=True)
    lit = dataclasses.replace(fire, media=(dataclasses.replace(fire.media[0], lights_surfaces=True),))
    return {
        "smoke": smoke,
        "depth of field (f/0.25, focus 3 m before the smoke)": dataclasses.replace(
            smoke, camera=dataclasses.replace(cam, aperture=Aperture(0.1, focus))),
        "motion blur: the camera moving": dataclasses.replace(
            smoke, motion=Motion(camera=ObjectMotion(tuple(s @ cam.matrix_world for s in moving.steps),
                                                     cam.matrix_world))),
        "motion blur: the smoke moving": dataclasses.replace(
            smoke, motion=Motion(objects={medium.name: moving})),
        "fire": fire,
        "fire lighting the ground": lit,
    }


def run(quick: bool = False, log=print) -> list[dict]:
    width, height, grid, repeats = (64, 36, 32, 1) if quick else (160, 90, 64, 7)
    scenes = cases(width, height, grid)
    settings = RenderSettings(quality="AUTO")
    renderer = Renderer()

    def frame(name):        # a cache client per case: each keeps its own maps and fire points
        return lambda: render_samples(renderer, scenes[name], settings, SAMPLES, client=name)

    for name in scenes:        # compiles every program, fills the caches
        frame(name)()
    times = time_side_by_side({name: frame(name) for name in scenes}, repeats)
    renderer.release()
    fire = scenes["fire lighting the ground"].media[0]
    edited = dataclasses.replace(fire, emission_color=(1.0, 0.3, 0.1))

    def made_anew():
        fire_light_module._HALF_MAPS.clear()
        fire_light(fire)

    cpu = time_side_by_side({"new": made_anew, "edit": lambda: fire_light(edited)}, repeats)
    base = {"smoke": times["smoke"], "fire": times["fire"]}
    rows = []
    for name, seconds in times.items():
        against = "fire" if name.startswith("fire") else "smoke"
        rows.append(dict(case=name, seconds=seconds, ratio=seconds / base[against], against=against))
    for key, case in (("new", "the fire's points and maps (numpy, once per medium content)"),
                      ("edit", "the points again after an emission edit (the maps kept)")):
        rows.append(dict(case=case, seconds=cpu[key], ratio=cpu[key] / base["fire"], against="fire"))
    log(report(rows, width, height))
    return rows


def report(rows: list[dict], width: int, height: int) -> str:
    lines = [f"{SAMPLES} samples at {width}x{height}, AUTO quality, warm caches; ratios to the frame "
             "without the effect, measured side by side in one run.", "",
             "| frame | s/frame | ratio | against |", "|---|---|---|---|"]
    lines += [f"| {r['case']} | {r['seconds']:.3f} | {r['ratio']:.2f} | {r['against']} |" for r in rows]
    return "\n".join(lines)


if __name__ == "__main__":
    import sys

    run(quick="--quick" in sys.argv)
