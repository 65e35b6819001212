"""The frame planner (engine/frame_plan.py) without a GL context: which light faces a frame draws,
which maps each needs and how its pass finds the transmittance, and how the light passes end.
The media are described as the renderer uploads them (bindings.MediaGPU of MediumSlots) with
stand-ins for the grid textures (their non-zero bounds, their index scale)."""

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest

from tfm_addon.engine import Light, Medium, RenderSettings, Scene, gl_context, world_light
from tfm_addon.engine.frame_plan import WORLD_TFM_SIDE, plan_faces, plan_frame, plan_passes
from tfm_addon.engine.passes.bindings import MEDIUM_BOX, MEDIUM_GRID, MediaGPU, MediumSlot
from tfm_addon.engine.passes.scattering import (
    LIGHT_T_ANALYTIC,
    LIGHT_T_MARCH,
    LIGHT_T_NONE,
    LIGHT_T_TFM,
    LIGHT_T_UNIT,
)
from tfm_addon.scenes import grid_to_world, homogeneous_box_scene, look_at, translate_scale

SETTINGS = RenderSettings(map_resolution=256)


@pytest.fixture(autouse=True)
def no_gl(monkeypatch):
    """Planning makes no GL context."""
    def refuse(*args, **kwargs):
        raise AssertionError("the planner made a GL context")
    monkeypatch.setattr(gl_context.GLContext, "__init__", refuse)


def _box(center=(0.0, 0.0, 1.5), half=1.5) -> Medium:
    return Medium(sigma_a=(0.1,) * 3, sigma_s=(1.0,) * 3, box_to_world=translate_scale(center, half))


def _grid(n=32, center=(0.0, 0.0, 1.5)) -> Medium:
    d = np.zeros((n, n, n), np.float32)
    d[4:-4, 4:-4, 4:-4] = np.random.default_rng(n).random((n - 8,) * 3)     # sharp: a texel a voxel
    return Medium(sigma_a=(0.1,) * 3, sigma_s=(1.0,) * 3, density=d,
                  index_to_world=grid_to_world(d.shape, 3.0, center))


def _marched(*media) -> MediaGPU:
    """Every medium marched, a density grid through a stand-in of its texture."""
    slots = []
    for m in media:
        grid = None
        if m.density is not None:
            grid = SimpleNamespace(lo=(3.0, 3.0, 3.0), hi=tuple(float(n) - 4.0 for n in m.density.shape),
                                   index_scale=np.eye(4), key=("grid", m.grid_key))
        slots.append(MediumSlot(m, grid))
    return MediaGPU(MEDIUM_GRID, None, slots, [])


def _analytic(medium: Medium) -> MediaGPU:
    """A lone homogeneous box, analytic."""
    to_world = np.asarray(medium.box_to_world)
    first = SimpleNamespace(world_to_box=np.linalg.inv(to_world), box_to_world=to_world,
                            lo=(-1.0, -1.0, -1.0), hi=(1.0, 1.0, 1.0))
    return MediaGPU(MEDIUM_BOX, first, [], [])


def _scene(*lights, medium=None) -> Scene:
    base = homogeneous_box_scene(width=64, height=36)
    return dataclasses.replace(base, lights=tuple(lights), media=(medium or base.media[0],))


def _plan(scene, media, settings=SETTINGS, casts_shadows=True, seen_bounds=None, **kw):
    return plan_frame(scene, settings, list(scene.lights), media, casts_shadows=casts_shadows,
                      casters_bounds=None, seen_bounds=seen_bounds, map_res=settings.map_resolution, **kw)


POINT_INSIDE = Light(matrix_world=translate_scale((0.2, -0.1, 1.4), 1.0), power_w=600.0, kind="POINT")
POINT_OUTSIDE = Light(matrix_world=translate_scale((9.0, 0.0, 1.5), 1.0), power_w=600.0, kind="POINT")
SPOT = Light(matrix_world=look_at((-1.0, -3.0, 4.0), (0.0, 0.5, 1.0)), power_w=3000.0,
             spot_size_rad=math.radians(45), spot_blend=0.1)
SUN = Light(matrix_world=look_at((-3.0, -1.0, 5.0), (0, 0, 1.0)), power_w=3.0, kind="SUN")


def test_a_point_light_inside_a_medium_draws_six_faces_outside_those_that_reach_it():
    media = _marched(_grid())
    inside = _plan(_scene(POINT_INSIDE), media)
    assert len(inside.faces) == 6 and inside.culled == 0
    assert {f.light_t for f in inside.faces} == {LIGHT_T_TFM}
    assert all(f.reached == (0,) and 64 <= f.tfm_side <= 256 for f in inside.faces)
    outside = _plan(_scene(POINT_OUTSIDE), media)
    assert 1 <= len(outside.faces) <= 3 and outside.culled == 6 - len(outside.faces)
    assert all(f.reached == (0,) for f in outside.faces)
    assert outside.tfm_side == max(f.tfm_side for f in outside.faces)


def test_a_face_that_sees_a_visible_solid_is_kept_without_maps():
    """A face of a point light that reaches no medium but the solids the camera sees: a pass,
    no transmittance; without such solids it is culled."""
    media = _marched(_grid(center=(0.0, 0.0, 1.5)))
    ground = ((-5.0, -5.0, -0.1), (5.0, 5.0, 0.0))
    seen = _plan(_scene(POINT_OUTSIDE), media, seen_bounds=ground)
    alone = _plan(_scene(POINT_OUTSIDE), media)
    assert seen.culled < alone.culled
    assert len(seen.faces) + seen.culled == len(alone.faces) + alone.culled == 6
    assert {f.light_t for f in seen.faces if not f.reached} == {LIGHT_T_NONE}


@pytest.mark.parametrize("method, want", [("TFM", LIGHT_T_TFM), ("BRUTE_FORCE", LIGHT_T_MARCH),
                                          ("UNSHADOWED", LIGHT_T_UNIT)])
def test_the_method_sets_how_a_pass_finds_the_transmittance(method, want):
    scene = _scene(SPOT, SUN)
    plan = _plan(scene, _marched(_grid(), _box((2.5, 0.0, 1.0), 0.5)),
                 dataclasses.replace(SETTINGS, method=method))
    assert [f.light.kind for f in plan.faces] == ["SPOT", "SUN"]
    assert {f.light_t for f in plan.faces} == {want}
    assert all((f.tfm_side is not None) == (want == LIGHT_T_TFM) for f in plan.faces)
    assert all(f.shadow_map for f in plan.faces)


def test_a_light_that_casts_no_shadow_needs_no_map():
    light = dataclasses.replace(SPOT, cast_shadow=False)
    (face,) = _plan(_scene(light), _marched(_grid())).faces
    assert face.light_t == LIGHT_T_UNIT and not face.shadow_map and face.tfm_side is None
    (face,) = _plan(_scene(SPOT), _marched(_grid()), casts_shadows=False).faces
    assert face.light_t == LIGHT_T_TFM and not face.shadow_map
    (face,) = _plan(_scene(dataclasses.replace(SPOT, use_tfm=False)), _marched(_grid())).faces
    assert face.light_t == LIGHT_T_NONE


def test_a_lone_homogeneous_box_is_analytic():
    box = _box()
    (face,) = _plan(_scene(SPOT, medium=box), _analytic(box)).faces
    assert face.light_t == LIGHT_T_ANALYTIC and face.tfm_side is None and face.reached == (0,)


def test_the_tfm_side_follows_the_finest_grid_a_face_reaches():
    """FOOTPRINT: a finer grid asks for a larger map (up to the map resolution); a box beside a
    grid does not set the side."""
    coarse, fine = _grid(32), _grid(128)
    settings = dataclasses.replace(SETTINGS, tfm_resolution="FOOTPRINT", map_resolution=1024)
    sides = {}
    for name, media in {"coarse": _marched(coarse), "fine": _marched(fine),
                        "box and fine": _marched(_box(half=1.4), fine)}.items():
        (face,) = _plan(_scene(SPOT), media, settings, image_side=1024).faces
        sides[name] = face.tfm_side
    assert 64 <= sides["coarse"] < sides["fine"] <= 1024, sides       # seen: 64 (the least), 80
    assert sides["box and fine"] == sides["fine"]


@pytest.mark.parametrize("faces, accumulate, active, lone, clear", [
    (1, False, False, True, False),     # one pass over every pixel composes its own image
    (2, False, False, False, False),    # two passes: the composite pass follows
    (0, False, False, True, False),     # no light: the ambient pass alone
    (1, False, True, False, True),      # the active pixels only: cleared targets, composite pass
    (1, True, True, True, False),       # a sample of one pass adds itself into the sums
    (3, True, False, False, False),
])
def test_how_the_light_passes_end(faces, accumulate, active, lone, clear):
    planned = [SimpleNamespace(field=False)] * faces
    got = plan_passes(planned, lights=2, accumulate=accumulate, active=active)
    assert got == dict(passes=tuple(planned), lone=lone, clear_targets=clear, steps=2 + 2 + max(faces, 1))


def _world(n=8):
    """A grey world's suns (engine/world_light.py)."""
    return tuple(world_light.world_suns((0.05, 0.05, 0.05), n))


def test_the_world_field_carries_the_world_s_light_to_bounded_media():
    scene = _scene(SPOT, *_world())
    media = _marched(_grid())
    plan = _plan(scene, media, world_field=True, seen_bounds=(np.full(3, -1.0), np.full(3, 1.0)))
    world = [f for f in plan.faces if f.light.from_world]
    assert len(world) == 8 and all(f.field for f in world) and not plan.faces[0].field
    assert all(f.light_t == LIGHT_T_TFM and f.tfm_side <= WORLD_TFM_SIDE for f in world)
    # the spot's pass marches the media first; the world's passes light the surfaces after it
    assert plan.passes[0].light is SPOT and not plan.lightless_first
    assert [f.field for f in plan.passes] == [False] + [True] * 8
    assert plan.steps == 2 + 9 + 9
    # with no solid in view the world's faces draw no pass (their maps still feed the field)
    unseen = _plan(scene, media, world_field=True)
    assert sum(f.field for f in unseen.faces) == 8 and [f.light for f in unseen.passes] == [SPOT]
    # the world alone: the first pass lights with no face
    alone = _plan(_scene(*_world()), media, world_field=True, seen_bounds=(np.full(3, -1.0), np.full(3, 1.0)))
    assert alone.lightless_first and len(alone.passes) == 8 and alone.steps == 2 + 8 + 9


def test_the_world_field_waits_for_a_lattice_over_every_medium():
    scene = _scene(*_world())
    media = _marched(_grid())
    assert not any(f.field for f in _plan(scene, media).faces)          # the GL has no unit for it
    fogged = _marched(_grid())
    fogged.fog = Medium(sigma_a=(0.01,) * 3, sigma_s=(0.05,) * 3)
    assert not any(f.field for f in _plan(scene, fogged, world_field=True).faces)
    unlit = tuple(dataclasses.replace(s, lights_medium=False) for s in _world())
    assert not any(f.field for f in _plan(_scene(*unlit), media, world_field=True).faces)


def test_a_scene_plans_its_lights_in_order_with_their_steps():
    scene = _scene(SPOT, POINT_INSIDE, SUN)
    plan = _plan(scene, _marched(_grid()))
    assert [f.light.kind for f in plan.faces] == ["SPOT"] + ["POINT"] * 6 + ["SUN"]
    assert plan.steps == 2 + 3 + 8 and not plan.lone
    faces, culled = plan_faces(scene, SETTINGS, SUN, _marched(_grid()), casts_shadows=True,
                               casters_bounds=None, seen_bounds=None, map_res=256)
    assert [f.frame.key for f in faces] == [plan.faces[-1].frame.key] and culled == 0
