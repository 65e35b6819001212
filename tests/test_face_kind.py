"""The light face's kind compiled into its light pass (passes/scattering.face_defines: sun or not,
emission profile, shadow map, gobo): each face kind compiles its own program, and each light kind
gives the numpy reference's frame."""

import dataclasses

import numpy as np
import pytest
from references import render_reference

from tfm_addon.engine import Light, Renderer, RenderSettings, Scene
from tfm_addon.engine.metrics import ssim
from tfm_addon.scenes import box_mesh, gobo_box_scene, look_at, plane_mesh, smoke_scene, translate_scale

SETTINGS = RenderSettings(view_steps=64, light_steps=64, map_resolution=96, coefficients=6)


def _scenes() -> dict:
    spot = smoke_scene(width=64, height=36, n=32, with_ground=True)
    lit = {"spot, shadow": spot,
           "spot, no solid": dataclasses.replace(spot, meshes=()),
           "gobo": gobo_box_scene(width=64, height=36)}
    kinds = {"sun": Light(matrix_world=look_at((-3.0, -1.0, 5.0), (0, 0, 1.0)), power_w=3.0, kind="SUN"),
             "point": Light(matrix_world=translate_scale((0.3, -0.2, 1.4), 1.0), power_w=600.0, kind="POINT"),
             "area": Light(matrix_world=look_at((-1.5, -1.5, 3.5), (0, 0, 1.0)), power_w=1500.0, kind="AREA",
                           size_m=(0.5, 0.5))}
    for name, light in kinds.items():
        lit[name] = Scene(camera=spot.camera, lights=(light,), media=(spot.media[0],),
                          meshes=(plane_mesh((0, 0, 0), 8.0), box_mesh((0.8, 0.0, 0.5), (0.3, 0.3, 1.0))))
    return lit


def _frame(scene):
    r = Renderer()
    try:
        image = r.render(scene, SETTINGS).combined
        kinds = {tuple(dict(k[2]).get(n) for n in ("FACE_ORTHO", "FACE_PROFILE", "FACE_SHADOW", "FACE_GOBO"))
                 for k in r.gl._programs if k[1] == "scatter.frag" and dict(k[2]).get("HAS_LIGHT")}
    finally:
        r.release()
    return image, kinds


@pytest.mark.parametrize("name", ["spot, shadow", "spot, no solid", "gobo", "sun", "point", "area"])
def test_each_face_kind_compiles_its_program_and_gives_the_reference(name):
    scene = _scenes()[name]
    image, kinds = _frame(scene)
    ortho = {"sun": 1}.get(name, 0)
    shadow = 0 if name == "spot, no solid" else 1
    assert {k[0] for k in kinds} == {ortho} and {k[2] for k in kinds} <= {0, 1}
    assert {k[3] for k in kinds} == {int(name == "gobo")}
    if name != "point":          # a point light's faces may see no solid: their maps are skipped
        assert {k[2] for k in kinds} == {shadow}
    ref = render_reference(scene, SETTINGS, view_steps=64, light_steps=64).combined[..., :3]
    peak = float(ref.max())
    assert peak > 0.02
    s = ssim(image[..., :3], ref)
    ratio = image[..., :3].sum(axis=(0, 1)) / ref.sum(axis=(0, 1))
    print(f"{name}: SSIM {s:.4f}, brightness {np.round(ratio, 4)}")
    assert s >= 0.98
    assert np.all(np.abs(ratio - 1.0) <= 0.015), ratio
