"""Lights and edits inside Blender: what a spot's scale and use_shadow do (against Cycles), the volume's
clipping, and a mesh edit that leaves the medium alone."""

import dataclasses
import importlib

import bpy
import numpy as np
from blender_helpers import MODULE, SETTINGS, render_passes, smoke

from tfm_addon.blender import scene_builder
from tfm_addon.engine import Renderer, metrics

CYCLES_SAMPLES = 1024           # 96x54: a few seconds each on 2 cores


def _mod(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.blender.{name}")


def _extract(**kwargs):
    return _mod("extract").extract(bpy.context.evaluated_depsgraph_get(), **kwargs)


def _cycles(tmp_path, name):
    scene_builder.cycles_single_scattering(bpy.context.scene, samples=CYCLES_SAMPLES)
    image = render_passes(tmp_path, name)["Combined"]
    bpy.context.scene.render.engine = 'TFM'
    return image


def _render(scene):
    r = Renderer()
    try:
        return r.render(scene, SETTINGS).combined
    finally:
        r.release()


def test_a_non_uniformly_scaled_spot_renders_the_ellipse_cycles_renders(blank, tmp_path):
    made = scene_builder.build(smoke(width=96, height=54, n=32), str(tmp_path), settings=SETTINGS)
    ob = made["lights"][0]
    ob.scale = (1.8, 0.7, 1.3)
    scene = _extract().scene()
    light = scene.lights[0]
    np.testing.assert_allclose(light.cone_scale, (1.8 / 1.3, 0.7 / 1.3), rtol=1e-5)
    tfm = render_passes(tmp_path, "tfm")["Combined"]
    cycles = _cycles(tmp_path, "cycles")
    round_cone = _render(dataclasses.replace(scene, lights=(dataclasses.replace(light, cone_scale=(1, 1)),)))
    s_tfm, s_round = metrics.ssim(tfm, cycles), metrics.ssim(round_cone, cycles)
    ratio = metrics.brightness_ratio(tfm, cycles)
    print(f"elliptical spot vs Cycles ({CYCLES_SAMPLES} spp): SSIM {s_tfm:.4f} (a round cone: "
          f"{s_round:.4f}), brightness ratio {ratio:.4f}")
    assert s_tfm >= 0.98 and abs(ratio - 1.0) <= 0.03
    assert s_round < s_tfm - 0.02


def test_use_shadow_off_lets_the_light_through_solids_and_medium_as_cycles_does(blank, tmp_path):
    made = scene_builder.build(smoke(width=96, height=54, n=32), str(tmp_path), settings=SETTINGS)
    made["lights"][0].data.use_shadow = False
    scene = _extract().scene()
    light = scene.lights[0]
    assert light.cast_shadow is False
    tfm = render_passes(tmp_path, "tfm")["Combined"]
    cycles = _cycles(tmp_path, "cycles")
    shadowed = _render(dataclasses.replace(scene, lights=(dataclasses.replace(light, cast_shadow=True),)))
    s_tfm, s_shadowed = metrics.ssim(tfm, cycles), metrics.ssim(shadowed, cycles)
    ratio = metrics.brightness_ratio(tfm, cycles)
    print(f"use_shadow off vs Cycles ({CYCLES_SAMPLES} spp): SSIM {s_tfm:.4f} (shadowed: "
          f"{s_shadowed:.4f}), brightness ratio {ratio:.4f}")
    assert s_tfm >= 0.98 and abs(ratio - 1.0) <= 0.03
    assert s_shadowed < s_tfm - 0.05


def test_the_volume_clipping_trims_the_volume_s_bounds_as_cycles_does(blank, tmp_path):
    """Cycles uses Volume ▸ Render ▸ Clipping only to build its volume's mesh (intern/cycles/scene/
    volume.cpp): voxels of at least the clipping, grown by one to their face neighbours, meshed by
    the OpenVDB leaf blocks (8³, at file indices that are multiples of 8) that hold any; inside the
    mesh every value renders, those below the clipping too. The medium read is that density."""
    from scipy import ndimage

    assert bpy.data.volumes.new("Default").render.clipping == np.float32(0.001)   # Blender's default
    source = smoke(width=48, height=32, n=32)
    made = scene_builder.build(source, str(tmp_path), settings=SETTINGS)
    clipping = 0.2
    made["medium"].data.render.clipping = clipping
    medium = _extract().media[0]
    full = np.asarray(source.media[0].density)          # the file's voxels, from index (0, 0, 0)
    grown = ndimage.binary_dilation(full >= clipping, ndimage.generate_binary_structure(3, 1))
    padded = np.pad(grown, [(0, -n % 8) for n in full.shape])
    blocks = padded.reshape(padded.shape[0] // 8, 8, padded.shape[1] // 8, 8, padded.shape[2] // 8, 8)
    inside = blocks.any(axis=(1, 3, 5)).repeat(8, 0).repeat(8, 1).repeat(8, 2)[
        :full.shape[0], :full.shape[1], :full.shape[2]]
    want = np.where(inside, full, 0.0)
    to_file = np.linalg.solve(source.media[0].index_to_world, medium.index_to_world)   # read -> file indices
    offset = np.rint(to_file[:3, 3]).astype(int)
    got = np.asarray(medium.density)
    window = want[offset[0]:offset[0] + got.shape[0], offset[1]:offset[1] + got.shape[1],
                  offset[2]:offset[2] + got.shape[2]]
    np.testing.assert_array_equal(got, window.astype(got.dtype))
    assert medium.clipping == 0.0
    assert ((full > 0) & (full < clipping) & inside).any()     # below the clipping, rendered
    assert ((full > 0) & ~inside).any()                          # left out with its block


def test_a_mesh_edit_next_to_the_volume_reads_no_grid(blank, tmp_path):
    Change = _mod("changes").Change
    changes = _mod("changes")
    made = scene_builder.build(smoke(width=48, height=32, n=32), str(tmp_path), settings=SETTINGS)
    session = _mod("viewport").ViewportSession()
    session.update(bpy.context.evaluated_depsgraph_get())
    assert session.extraction.media
    seen = []

    def handler(scene, depsgraph):
        seen.append(changes.changes_from_depsgraph(depsgraph, session.extraction.medium_sources))

    def flags_after(edit):
        seen.clear()
        edit()
        bpy.context.view_layer.update()
        flags = Change.NONE
        for f in seen:
            flags |= f
        return flags

    cache = _mod("volumes").grid_cache
    bpy.app.handlers.depsgraph_update_post.append(handler)
    try:
        bar = made["meshes"][0]

        def move_vertex():
            bar.data.vertices[0].co.x += 0.05
            bar.data.update()
        for edit in (lambda: setattr(bar.location, "z", bar.location.z + 0.1), move_vertex):
            flags = flags_after(edit)
            assert Change.SOLIDS in flags and Change.MEDIUM not in flags, flags
            reads, hits = cache.reads, cache.hits
            medium = session.extraction.media[0]
            session.update(bpy.context.evaluated_depsgraph_get(), flags)
            assert (cache.reads, cache.hits) == (reads, hits)       # the grid was not looked at
            assert session.extraction.media[0] is medium
        # The medium's own edit, and a mesh that takes a volume material, still flag the medium.
        assert Change.MEDIUM in flags_after(lambda: setattr(made["medium"].location, "x", 0.1))
        bar.data.materials.clear()
        volume_material = made["medium"].data.materials[0]
        assert Change.MEDIUM in flags_after(lambda: bar.data.materials.append(volume_material))
    finally:
        bpy.app.handlers.depsgraph_update_post.remove(handler)


def test_a_mesh_that_is_a_smoke_domain_may_be_the_medium(addon):
    """A mesh turned into a gas domain (no volume material, not yet the medium) flags the medium,
    so the viewport reads its cache (its edits were taken for the solids' alone). A stand-in
    object: a real domain must not be evaluated in this process (BLENDER.md)."""
    from types import SimpleNamespace

    changes = _mod("changes")

    def mesh(modifiers):
        return SimpleNamespace(name="Domain", original=SimpleNamespace(modifiers=modifiers),
                               material_slots=())
    gas = SimpleNamespace(type='FLUID', fluid_type='DOMAIN', show_viewport=True, show_render=True,
                          domain_settings=SimpleNamespace(domain_type='GAS'))
    liquid = SimpleNamespace(**{**vars(gas), "domain_settings": SimpleNamespace(domain_type='LIQUID')})
    assert changes._may_be_medium(mesh([gas]), "Smoke") is True
    assert changes._may_be_medium(mesh([liquid]), "Smoke") is False
    assert changes._may_be_medium(mesh([]), None) is False
