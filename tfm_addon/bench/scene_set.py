"""The benchmark's scenes, made by code: nothing is downloaded.

Suzanne's triangles come from ``data/suzanne.npz``, written once from Blender's
``bpy.ops.mesh.primitive_monkey_add(size=2)`` by ``python -m tfm_addon.bench.scene_set --suzanne``
(so that the renderer part of the benchmark runs without Blender, on a GPU machine).
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import scenes
from ..engine.scene import Scene
from .config import Config

SUZANNE = Path(__file__).with_name("data") / "suzanne.npz"


@dataclass(frozen=True)
class BenchScene:
    key: str
    title: str
    scene: Scene
    description: str

    @property
    def homogeneous(self) -> bool:
        return bool(self.scene.media) and self.scene.media[0].density is None

    def grid_text(self) -> str:
        m = self.scene.media[0]
        if m is None or m.density is None:
            return "homogeneous"
        return "x".join(str(s) for s in m.density.shape)


def suzanne_mesh() -> tuple[np.ndarray, np.ndarray]:
    """Blender's Suzanne (507 vertices, 968 triangles) as ``primitive_monkey_add(size=2)``."""
    data = np.load(SUZANNE)
    return data["vertices"], data["triangles"]


def write_suzanne(path: Path = SUZANNE) -> Path:
    """Take Suzanne from Blender (needs bpy) and store her triangles."""
    import bpy

    bpy.ops.mesh.primitive_monkey_add(size=2.0)
    me = bpy.context.active_object.data
    me.calc_loop_triangles()
    v = np.array([x.co[:] for x in me.vertices], np.float32)
    t = np.array([lt.vertices[:] for lt in me.loop_triangles], np.int32)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, vertices=v, triangles=t)
    return path


def resized(scene: Scene, width: int, height: int) -> Scene:
    cam = dataclasses.replace(scene.camera, width_px=width, height_px=height)
    return dataclasses.replace(scene, camera=cam)


DENSE_THICKNESS = 30.0


def build(config: Config, only: set[str] | None = None) -> list[BenchScene]:
    """The five scenes of the method table, at the run's sizes."""
    w, h = config.width, config.height
    out = []

    def want(key):
        return only is None or key in only

    if want("smoke"):
        n = config.smoke_n
        out.append(BenchScene("smoke", f"smoke {n}^3", scenes.paper_smoke_scene(w, h, n),
                              f"turbulent smoke {n}^3 filling the frame, one wide spot "
                              "(the paper's smoke set-up)"))
    if want("suzanne"):
        v, t = suzanne_mesh()
        n = config.suzanne_n
        out.append(BenchScene("suzanne", f"Suzanne {n}^3", scenes.suzanne_scene(v, t, w, h, n),
                              f"Blender's Suzanne voxelised in {n}^3 at constant density: sharp steps "
                              "and flat regions (the paper's bunny case); she shadows the ground"))
    if want("cloud"):
        shape = config.cloud_shape
        out.append(BenchScene("cloud", "cloud " + "x".join(map(str, shape)),
                              scenes.cloud_scene(config.cloud_width, config.cloud_height, shape),
                              "a procedural cumulus, 12 m wide, over a ground plane it shadows; "
                              "a narrow spot high up stands in for the sun"))
    if want("gobo"):
        out.append(BenchScene("gobo", "gobo box (homogeneous)", scenes.gobo_box_scene(w, h, with_bar=True),
                              "homogeneous fog in a 3 m box lit through a high-frequency ring gobo "
                              "(the paper's Fig. 5), a bar casting a shaft"))
    if want("dense"):
        n = config.smoke_n
        out.append(BenchScene("dense", f"dense smoke {n}^3",
                              scenes.dense_smoke_scene(w, h, n, thickness=DENSE_THICKNESS),
                              f"the smoke with sigma x{DENSE_THICKNESS:g}: steep transmittance along the "
                              "light rays, where a truncated series rings (the paper's Fig. 7)"))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m tfm_addon.bench.scene_set")
    parser.add_argument("--suzanne", action="store_true", help="rewrite data/suzanne.npz from Blender")
    args = parser.parse_args()
    if args.suzanne:
        print(write_suzanne())


if __name__ == "__main__":
    main()
