"""Sun, point and area lights and several media: the GPU renderer against the numpy double march
(tfm_addon.engine.reference, which shares no code with it), and the map counters per face."""

import dataclasses
import math

import numpy as np
import pytest
from references import render_reference

from tfm_addon.engine import Camera, Light, Medium, RenderSettings, Scene
from tfm_addon.engine.metrics import brightness_ratio, ssim
from tfm_addon.scenes import box_mesh, grid_to_world, look_at, plane_mesh, smoke_density, translate_scale

STEPS = dict(view_steps=96, light_steps=96)
SETTINGS = RenderSettings(coefficients=8, map_resolution=256, **STEPS)
N = 32


def _camera(w=96, h=54):
    return Camera(matrix_world=look_at((0.0, -6.5, 1.6), (0, 0, 1.1)), width_px=w, height_px=h, lens_mm=40.0)


def _smoke(center=(0, 0, 1.2), size=2.0, sigma_s=(2.0, 2.0, 2.0), sigma_a=(0.2, 0.2, 0.2), g=0.0,
           seed=1, name="Smoke"):
    return Medium(sigma_a=sigma_a, sigma_s=sigma_s, anisotropy=g, density=smoke_density(N, seed=seed),
                  index_to_world=grid_to_world((N, N, N), size, center), name=name)


def _fog(center=(0, 0, 1.2), size=3.0, sigma=0.5):
    """A box of fog as a constant grid (so that it has TFMs)."""
    d = np.ones((16, 16, 16), np.float32)
    return Medium(sigma_a=(0.1 * sigma,) * 3, sigma_s=(sigma,) * 3, density=d,
                  index_to_world=grid_to_world((16, 16, 16), size, center), name="Fog")


def _sun(direction_to=(0, 0, 1.0), eye=(-3.0, -1.0, 5.0), strength=3.0):
    return Light(matrix_world=look_at(eye, direction_to), power_w=strength, kind="SUN", name="Sun")


def _compare(renderer, scene, ssim_min=0.99, bright=0.02, settings=SETTINGS, ref_steps=STEPS):
    ref = render_reference(scene, **ref_steps)
    out = renderer.render(scene, settings)
    s, b = ssim(out.rgb, ref.rgb), brightness_ratio(out.rgb, ref.rgb)
    assert s >= ssim_min and abs(b - 1) <= bright, (s, b)
    return out, ref


def test_sun_through_smoke_with_a_shaft_builds_one_tfm(renderer):
    scene = Scene(camera=_camera(), lights=(_sun(),), media=(_smoke(),),
                  meshes=(box_mesh((-1.2, -0.4, 3.2), (0.15, 1.2, 0.15), name="Bar"),
                          plane_mesh((0, 0, 0), 8.0)))
    renderer.clear_maps()
    before = dict(renderer.counters)
    out, ref = _compare(renderer, scene)
    assert renderer.counters["tfms"] - before.get("tfms", 0) == 1
    assert renderer.counters["shadow_maps"] - before.get("shadow_maps", 0) == 1
    # The bar's shaft: light scattered inside the medium must show the shadow as the reference does.
    assert ssim(out.passes["scattering"], ref.passes["scattering"]) >= 0.98


def test_point_light_inside_fog_builds_at_most_six_tfms(renderer):
    light = Light(matrix_world=translate_scale((0.2, 0.1, 1.3), 1.0), power_w=800.0, kind="POINT")
    # A bar under the light: its shadow and shaft cross the boundaries of the cube faces.
    bar = box_mesh((0.2, 0.1, 0.8), (1.2, 0.12, 0.12), name="Bar")
    scene = Scene(camera=_camera(), lights=(light,), media=(_fog(),),
                  meshes=(bar, plane_mesh((0, 0, 0), 8.0)))
    renderer.clear_maps()
    before = renderer.counters["tfms"]
    out, ref = _compare(renderer, scene)
    assert 1 <= renderer.counters["tfms"] - before <= 6
    assert ssim(out.passes["scattering"], ref.passes["scattering"]) >= 0.98


def test_point_light_inside_smoke_matches_reference(renderer):
    light = Light(matrix_world=translate_scale((0.0, 0.0, 1.2), 1.0), power_w=600.0, kind="POINT")
    scene = Scene(camera=_camera(), lights=(light,), media=(_smoke(),), meshes=(plane_mesh((0, 0, 0), 8.0),))
    _compare(renderer, scene)


def test_point_light_outside_with_one_face_toward_the_medium_builds_one(renderer):
    # 4 m above a 2 m smoke: only the downward face sees it; no solids, so the others are culled.
    light = Light(matrix_world=translate_scale((0.0, 0.0, 6.0), 1.0), power_w=3000.0, kind="POINT")
    scene = Scene(camera=_camera(), lights=(light,), media=(_smoke(),))
    renderer.clear_maps()
    before = dict(renderer.counters)
    _compare(renderer, scene)
    assert renderer.counters["tfms"] - before.get("tfms", 0) == 1
    assert renderer.counters["faces_culled"] - before.get("faces_culled", 0) == 5


def test_area_light_matches_reference(renderer):
    light = Light(matrix_world=look_at((-1.5, -1.5, 3.5), (0, 0, 1.0)), power_w=1500.0, kind="AREA",
                  size_m=(0.5, 0.5), name="Area")
    scene = Scene(camera=_camera(), lights=(light,), media=(_smoke(),), meshes=(plane_mesh((0, 0, 0), 8.0),))
    out, _ = _compare(renderer, scene)       # the reference's point: close for a light this small and far
    assert not any("Area light 'Area'" in w for w in out.warnings)     # its shape renders: nothing to say


def test_two_overlapping_media_with_different_materials(renderer):
    a = _smoke(center=(-0.4, 0, 1.2), size=2.0, name="A")
    b = _smoke(center=(0.5, 0.2, 1.4), size=1.6, sigma_s=(4.0, 4.0, 4.0), sigma_a=(0.6, 0.6, 0.6), g=0.5,
               seed=5, name="B")
    spot = Light(matrix_world=look_at((-2.5, -1.0, 4.0), (0, 0, 1.0)), power_w=2000.0,
                 spot_size_rad=math.radians(45), spot_blend=0.2)
    scene = Scene(camera=_camera(), lights=(spot, _sun(strength=1.0)), media=(a, b),
                  meshes=(plane_mesh((0, 0, 0), 8.0),))
    out, _ = _compare(renderer, scene)
    assert not any("extinction colour" in w for w in out.warnings)


def test_one_volume_instanced_three_times_shares_one_texture(renderer):
    base = _smoke(size=1.2)
    media = tuple(dataclasses.replace(base, index_to_world=grid_to_world((N, N, N), 1.2, (x, 0.0, 1.0)),
                                      name=f"Copy{i}") for i, x in enumerate((-1.4, 0.0, 1.4)))
    scene = Scene(camera=_camera(), lights=(_sun(),), media=media, meshes=(plane_mesh((0, 0, 0), 8.0),))
    renderer.clear_maps()
    before = renderer.counters["grid_uploads"]
    _compare(renderer, scene)
    assert renderer.counters["grid_uploads"] - before == 1


def test_editing_one_volume_rebuilds_only_the_maps_of_lights_that_reach_it(renderer):
    left, right = _smoke(center=(-2.0, 0, 1.2), size=1.5, name="L"), _smoke(center=(2.0, 0, 1.2), size=1.5,
                                                                            name="R", seed=3)
    spot_l = Light(matrix_world=look_at((-2.0, 0.0, 4.5), (-2.0, 0, 1.2)), spot_size_rad=math.radians(30),
                   name="SpotL")
    spot_r = Light(matrix_world=look_at((2.0, 0.0, 4.5), (2.0, 0, 1.2)), spot_size_rad=math.radians(30),
                   name="SpotR")
    scene = Scene(camera=_camera(64, 36), lights=(spot_l, spot_r), media=(left, right))
    renderer.render(scene, SETTINGS)
    before = dict(renderer.counters)
    edited = dataclasses.replace(right, density=right.density * 0.5)
    renderer.render(dataclasses.replace(scene, media=(left, edited)), SETTINGS)
    assert renderer.counters["tfms"] - before["tfms"] == 1
    assert renderer.counters["grid_uploads"] - before["grid_uploads"] == 1


def test_grid_budget_covers_all_media_largest_first(renderer):
    small = _smoke(name="Small")
    d = smoke_density(48, seed=2)
    large = Medium(sigma_a=(0.2,) * 3, sigma_s=(2.0,) * 3, density=d,
                   index_to_world=grid_to_world(d.shape, 2.0, (0.5, 0.0, 1.0)), name="Large")
    budget = (N**3 + 48**3) * 4 - 1
    scene = Scene(camera=_camera(64, 36), lights=(_sun(),), media=(small, large))
    out = renderer.render(scene, dataclasses.replace(SETTINGS, max_grid_bytes=budget))
    notes = [w for w in out.warnings if "budget" in w]
    assert len(notes) == 1 and "'Large'" in notes[0] and "'Small'" not in notes[0], out.warnings


@pytest.mark.parametrize("kind", ["POINT", "SUN"])
def test_brute_force_light_kinds_match_the_tfm(renderer, kind):
    """The GPU double march and the TFM agree for the cube and orthographic faces."""
    light = (Light(matrix_world=translate_scale((0.3, -0.2, 1.4), 1.0), power_w=600.0, kind="POINT")
             if kind == "POINT" else _sun())
    scene = Scene(camera=_camera(64, 36), lights=(light,), media=(_smoke(),))
    tfm = renderer.render(scene, SETTINGS)
    brute = renderer.render(scene, dataclasses.replace(SETTINGS, method="BRUTE_FORCE"))
    assert ssim(tfm.rgb, brute.rgb) >= 0.99
    assert abs(brightness_ratio(tfm.rgb, brute.rgb) - 1) <= 0.02


def test_auto_rule_reads_every_light_kind_through_its_faces():
    """AUTO's optical depth follows the rays of each kind's faces: a sun's parallel rays and a
    point light's cube faces cross the smoke as a spot's cone does (no renderer needed)."""
    from tfm_addon.engine import quality

    spot = Light(matrix_world=look_at((-3.0, -1.0, 5.0), (0, 0, 1.0)), spot_size_rad=math.radians(40))
    point = Light(matrix_world=translate_scale((0.0, 0.0, 1.2), 1.0), kind="POINT")
    depth = {light.kind: quality.medium_stats(Scene(camera=_camera(), lights=(light,), media=(_smoke(),)))
             .optical_depth for light in (spot, _sun(), point)}
    assert depth["SPOT"] > 0.5
    assert 0.7 * depth["SPOT"] <= depth["SUN"] <= 1.3 * depth["SPOT"]
    assert 0.4 * depth["SPOT"] <= depth["POINT"] <= depth["SPOT"]     # from the centre: half a chord


@pytest.mark.parametrize("kind", ["POINT", "SUN", "AREA"])
@pytest.mark.parametrize("sampling", ["WORLD", "PROJECTIVE"])
def test_homogeneous_box_analytic_path_for_every_face(renderer, kind, sampling):
    """A fog box (the analytic transmittance, no TFM) lit through cube and orthographic faces."""
    box = Medium(sigma_a=(0.05,) * 3, sigma_s=(0.4, 0.35, 0.3), anisotropy=0.3,
                 box_to_world=translate_scale((0, 0, 1.2), 1.2))
    light = {"POINT": Light(matrix_world=translate_scale((0.3, -0.2, 1.5), 1.0), power_w=500.0, kind="POINT"),
             "SUN": _sun(strength=2.0),
             "AREA": Light(matrix_world=look_at((-1.0, -1.2, 3.2), (0, 0, 1.0)), power_w=800.0,
                           kind="AREA")}[kind]
    scene = Scene(camera=_camera(64, 36), lights=(light,), media=(box,),
                  meshes=(box_mesh((0.2, 0.1, 2.9), (0.3, 0.3, 0.1), name="Lid"), plane_mesh((0, 0, 0), 8.0)))
    before = renderer.counters["tfms"]
    _compare(renderer, scene, settings=dataclasses.replace(SETTINGS, view_steps=128, sampling=sampling),
             ref_steps=dict(view_steps=256, light_steps=32))
    assert renderer.counters["tfms"] == before


def test_a_fog_box_and_a_grid_together(renderer):
    """A homogeneous box marched with a density grid it overlaps (no analytic path), a point light
    and a spot: against the reference."""
    fog = Medium(sigma_a=(0.02,) * 3, sigma_s=(0.25, 0.2, 0.15), anisotropy=-0.2,
                 box_to_world=translate_scale((0.8, 0.0, 1.0), 1.5), name="Fog")
    spot = Light(matrix_world=look_at((-2.5, -1.0, 4.0), (0, 0, 1.0)), power_w=1500.0,
                 spot_size_rad=math.radians(45), spot_blend=0.2)
    point = Light(matrix_world=translate_scale((1.2, -0.5, 1.4), 1.0), power_w=300.0, kind="POINT")
    scene = Scene(camera=_camera(), lights=(spot, point), media=(_smoke(), fog),
                  meshes=(plane_mesh((0, 0, 0), 8.0),))
    out, _ = _compare(renderer, scene)
    assert any("extinction colour" in w for w in out.warnings)     # grey smoke, coloured fog


def test_a_gl_with_16_texture_units_renders_three_grids_and_names_the_fourth(fresh):
    """Where the fragment shader has 16 texture units (the fewest GL guarantees) a pass reads 3
    density grids (the 4th grid's unit is 16): every sampler a program then declares has a unit
    below 16, the 4th medium is named and the image is that of the first three."""
    from tfm_addon.engine.passes import bindings
    from tfm_addon.engine.passes.fire import has_fire_unit
    from tfm_addon.engine.passes.fluence import has_fluence_units
    info = fresh.gl.ctx.info
    info["GL_MAX_TEXTURE_IMAGE_UNITS"] = 16        # moderngl keeps this dict: the GL now says 16
    assert bindings.max_grids(fresh.gl) == 3
    always = {n: u for n, u in bindings.UNIT.items()
              if u not in bindings.GRID_UNITS[3:]
              and n not in ("u_glow", "u_fire", "u_brick_index", "u_ms_fluence")}
    assert not bindings.has_glow_unit(fresh.gl)
    assert not bindings.has_sparse_unit(fresh.gl)   # a sparse grid: uploaded dense from its coarse copy
    assert not has_fire_unit(fresh.gl)      # a fire's light on the solids: said, not rendered
    assert not has_fluence_units(fresh.gl)  # the lattice's fields: said, the slab term stands in
    assert max(always.values()) < 16, always
    media = tuple(_smoke(center=(x, 0.0, 1.2), size=1.0, seed=i + 1, name=f"S{i}")
                  for i, x in enumerate((-1.5, -0.5, 0.5, 1.5)))
    scene = Scene(camera=_camera(48, 27), lights=(_sun(),), media=media)
    out = fresh.render(scene, SETTINGS)
    assert any("At most 3 distinct density grids" in w and "'S3'" in w for w in out.warnings), out.warnings
    ref = render_reference(dataclasses.replace(scene, media=media[:3]), **STEPS)
    s, b = ssim(out.rgb, ref.rgb), brightness_ratio(out.rgb, ref.rgb)
    assert s >= 0.99 and abs(b - 1) <= 0.02, (s, b)


def test_replace_with_new_media_keeps_them():
    """``dataclasses.replace(scene, media=...)`` renders the media it is given, and a replace of
    anything else keeps the scene's media."""
    a, b, c = _smoke(name="A"), _smoke(name="B"), _smoke(name="C")
    bare, two = Scene(camera=_camera()), Scene(camera=_camera(), media=(a, b))
    names = [[m.name for m in s.media] for s in (
        dataclasses.replace(bare, media=(a, b)), dataclasses.replace(two, media=(c,)),
        dataclasses.replace(two, media=()), dataclasses.replace(two, lights=()))]
    assert names == [["A", "B"], ["C"], [], ["A", "B"]]


@pytest.mark.parametrize("skipped", ["empty grid", "unbounded fog"])
def test_auto_reads_the_first_medium_marched(renderer, skipped):
    """AUTO chooses from the first medium the renderer marches, not from one it skips ahead of
    it: behind an empty grid it chose 2 coefficients for a dense smoke (brightness 3.3 % off),
    behind unbounded fog the homogeneous medium's settings."""
    from tfm_addon.engine.renderer import effective_settings
    dense = _smoke(sigma_s=(12.0,) * 3, sigma_a=(1.0,) * 3)
    if skipped == "empty grid":
        ahead = dataclasses.replace(_smoke(), density=np.zeros((8, 8, 8), np.float32), name="Empty")
    else:
        ahead = Medium(sigma_a=(0.0,) * 3, sigma_s=(0.0,) * 3, name="Unbounded")
    auto = RenderSettings(quality="AUTO")
    alone = Scene(camera=_camera(64, 36), lights=(_sun(),), media=(dense,))
    behind = dataclasses.replace(alone, media=(ahead, dense))
    assert effective_settings(behind, auto) == effective_settings(alone, auto)
    ref = render_reference(alone, view_steps=128, light_steps=128)
    out = renderer.render(behind, auto)
    b = brightness_ratio(out.rgb, ref.rgb)
    assert ssim(out.rgb, ref.rgb) >= 0.999 and abs(b - 1) <= 0.01, b


def test_footprint_side_of_a_face_is_the_finest_its_grids_ask_for(fresh):
    """A spot through a fog box and a smoke grid: its FOOTPRINT TFM has the grid's side whatever the
    media's order (the box, first, set it: its 'voxel' is its half side, so 64 texels for 80)."""
    fog = Medium(sigma_a=(0.02,) * 3, sigma_s=(0.25,) * 3, box_to_world=translate_scale((0, 0, 1.2), 1.6),
                 name="Fog")
    spot = Light(matrix_world=look_at((-2.5, -1.0, 4.0), (0, 0, 1.0)), power_w=1500.0,
                 spot_size_rad=math.radians(45), spot_blend=0.2)
    # A sharp-edged density: one TFM texel per voxel (a smooth one gets one per three, which the
    # 64-texel minimum would hide).
    blocky = (smoke_density(64, seed=1) > 0.3).astype(np.float32)
    smoke = Medium(sigma_a=(0.2,) * 3, sigma_s=(6.0,) * 3, density=blocky,
                   index_to_world=grid_to_world((64, 64, 64), 2.0, (0, 0, 1.2)), name="Smoke")
    settings = dataclasses.replace(SETTINGS, map_resolution=512, tfm_resolution="FOOTPRINT")
    sides = []
    for media in ((smoke,), (smoke, fog), (fog, smoke)):
        fresh.clear_maps()
        fresh.render(Scene(camera=_camera(64, 36), lights=(spot,), media=media), settings, map_image_side=512)
        sides.append(sorted(k[4] for k in fresh._tfms.items if k[-1] != "alpha"))
    # The grid's own side (the fog box first once set 64, its half side taken as the voxel).
    assert sides[0] == sides[1] == sides[2] and sides[0][0] > 64, sides


def test_auto_reads_the_grid_whatever_the_media_order(renderer):
    """A fog box listed before a smoke grid: AUTO chooses the grid's settings, as with the grid
    first (it took the box's analytic-path settings: 8 coefficients, 100 light steps), and the
    frame matches the reference."""
    from tfm_addon.engine.quality import auto_settings
    fog = Medium(sigma_a=(0.02,) * 3, sigma_s=(0.25, 0.2, 0.15), anisotropy=-0.2,
                 box_to_world=translate_scale((0.8, 0.0, 1.0), 1.5), name="Fog")
    spot = Light(matrix_world=look_at((-2.5, -1.0, 4.0), (0, 0, 1.0)), power_w=1500.0,
                 spot_size_rad=math.radians(45), spot_blend=0.2)
    scenes = [Scene(camera=_camera(), lights=(spot,), media=media, meshes=(plane_mesh((0, 0, 0), 8.0),))
              for media in ((_smoke(), fog), (fog, _smoke()))]
    grid_first, box_first = (auto_settings(s, RenderSettings()) for s in scenes)
    assert box_first == grid_first and box_first.tfm_resolution == "FOOTPRINT", (box_first, grid_first)
    _compare(renderer, scenes[1], settings=RenderSettings(), ref_steps=dict(view_steps=192, light_steps=192))
