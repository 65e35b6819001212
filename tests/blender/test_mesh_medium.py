"""Media shaped by their mesh, against Cycles (single scattering, BLENDER.md settings), 160x90:
Suzanne and a UV sphere with a volume material, lit by a spot over a ground plane; the sphere's
shadow on the ground is round. Counters: a camera orbit rebuilds nothing of the shape, a mesh
edit rebuilds it once."""

import importlib
import math
import time

import bpy
import numpy as np
import pytest
from blender_helpers import MODULE, render_passes
from mathutils import Vector
from scipy import ndimage

from tfm_addon import scenes
from tfm_addon.blender import scene_builder
from tfm_addon.engine import Camera, Light, RenderSettings, Scene, metrics

SETTINGS = RenderSettings(view_steps=128, light_steps=128, map_resolution=256, coefficients=16)
# Suzanne at 2048 spp: its SSIM is 0.977 at 512 spp, 0.9807 at 2048 (see the assertion).
CYCLES_SAMPLES = {"suzanne": 2048, "sphere": 512}
AA_SAMPLES = 16           # TFM's antialiasing samples: Cycles' film is antialiased too


def _mod(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.{name}")


def _scene(kind: str) -> Scene:
    ground = scenes.plane_mesh((0, 0, 0), 10.0)
    if kind == "suzanne":
        light = Light(matrix_world=scenes.look_at((-2.2, -3.2, 3.6), (0, 0, 1.3)), power_w=2500.0,
                          spot_size_rad=math.radians(50), spot_blend=0.2, name="Key")
        eye, target = (1.2, -4.6, 1.7), (0.0, 0.0, 1.25)
    else:   # straight down, so that the sphere's shadow is a disc
        light = Light(matrix_world=scenes.look_at((0, 0, 5.0), (0, 0, 0), up=(0, 1, 0)),
                          power_w=3000.0, spot_size_rad=math.radians(70), spot_blend=0.1, name="Top")
        eye, target = (0.0, -5.5, 3.2), (0.0, 0.0, 0.7)
    camera = Camera(matrix_world=scenes.look_at(eye, target), width_px=160, height_px=90, lens_mm=40.0)
    return Scene(camera=camera, lights=(light,), meshes=(ground,))


def _add_medium(kind: str, builder):
    if kind == "suzanne":
        bpy.ops.mesh.primitive_monkey_add(size=2.0, location=(0.0, 0.0, 1.3))
        sigma_a, sigma_s = (0.4, 0.4, 0.4), (3.6, 3.6, 3.6)
    else:
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.8, location=(0.0, 0.0, 1.5))
        sigma_a, sigma_s = (0.3, 0.3, 0.3), (3.0, 3.0, 3.0)
    ob = bpy.context.active_object
    ob.data.materials.append(builder.volume_material(f"{kind} fog", sigma_a, sigma_s, grid=""))
    return ob


def _render_both(tmp_path, kind):
    builder = scene_builder
    builder.build(_scene(kind), str(tmp_path), settings=SETTINGS, samples=AA_SAMPLES)
    ob = _add_medium(kind, builder)
    tfm = render_passes(tmp_path, "tfm")["Combined"]
    messages = list(_mod("blender.final_render").last_messages)
    builder.cycles_single_scattering(bpy.context.scene, samples=CYCLES_SAMPLES[kind])
    t0 = time.perf_counter()
    cycles = render_passes(tmp_path, "cycles")["Combined"]
    return ob, tfm, cycles, time.perf_counter() - t0, messages


@pytest.mark.parametrize("kind", ["suzanne", "sphere"])
def test_mesh_medium_matches_cycles(blank, tmp_path, kind):
    _ob, tfm, cycles, seconds, messages = _render_both(tmp_path, kind)
    ssim = metrics.ssim(tfm, cycles)
    ratio = metrics.brightness_ratio(tfm, cycles)
    print(f"{kind} mesh medium vs Cycles ({CYCLES_SAMPLES[kind]} spp, {seconds:.1f} s): SSIM {ssim:.4f}, "
          f"brightness ratio {ratio:.4f}; messages {messages}")
    # Suzanne's eyes are open caps inside the head: Cycles' volume stack leaves the medium at the
    # first back face a ray meets, so its shadow rays skip the head behind the eyes (light leaks in
    # there) and it comes out ~1.5 % brighter around them, while the grid holds the union of the
    # shells (docs/architecture.md). Measured: SSIM 0.9807 (thin margin; deterministic seeds), the
    # sphere 0.9985.
    assert ssim >= 0.98 and abs(ratio - 1.0) < 0.03
    if kind == "sphere":
        assert messages == []
        # The shadow on the ground: darker than half the lit ground's brightness, below the
        # sphere's image. Its shape is a (projected) disc: it fills about pi/4 of its bounding box,
        # where the bounding box's shadow would fill nearly all of it; it matches Cycles' shadow.
        def shadow(image):
            lum = image[..., :3].mean(axis=-1)
            ground = image[..., 3] > 0.999
            rows = np.arange(lum.shape[0])[:, None] > lum.shape[0] * 0.55
            lit = np.percentile(lum[ground & rows], 90)
            dark, _ = ndimage.label(ground & rows & (lum < 0.5 * lit))
            # the dark region under the sphere (the ground outside the cone is dark too)
            return dark == dark[int(lum.shape[0] * 0.8), lum.shape[1] // 2]
        mine, theirs = shadow(tfm), shadow(cycles)
        assert mine.sum() > 60
        ys, xs = np.nonzero(mine)
        fill = mine.sum() / ((ys.ptp() + 1) * (xs.ptp() + 1))
        iou = (mine & theirs).sum() / (mine | theirs).sum()
        print(f"sphere shadow: {mine.sum()} px, fills {fill:.3f} of its box, IoU with Cycles {iou:.3f}")
        assert fill < 0.86 and iou > 0.85
    else:
        assert any("not closed" in m for _, m in messages)   # Suzanne's open eye sockets, said once
        assert sum("not closed" in m for _, m in messages) == 1


def test_orbit_rebuilds_nothing_and_an_edit_rebuilds_once(blank, tmp_path):
    builder = scene_builder
    builder.build(_scene("sphere"), str(tmp_path), settings=SETTINGS)
    ob = _add_medium("sphere", builder)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 64, 36
    cache = _mod("engine.mesh_volume").occupancy_cache
    worker = _mod("blender.render_worker").get_worker()
    render_passes(tmp_path, "first")
    built, counters = cache.counters["voxelisations"], dict(worker.counters)
    cam = scene.camera
    for angle in (30.0, 60.0, 90.0):
        a = math.radians(angle)
        cam.location = (5.5 * math.sin(a), -5.5 * math.cos(a), 3.2)
        direction = -np.asarray(cam.location) + (0, 0, 0.7)
        cam.rotation_mode = 'QUATERNION'
        cam.rotation_quaternion = Vector(direction).to_track_quat('-Z', 'Y')
        render_passes(tmp_path, f"orbit{angle:.0f}")
    after = dict(worker.counters)
    assert cache.counters["voxelisations"] == built
    for name in ("grid_uploads", "tfms", "shadow_maps"):
        assert after.get(name, 0) == counters.get(name, 0), name
    assert after["gbuffers"] == counters["gbuffers"] + 3          # the camera did move
    # An edit of the mesh: one new grid, then none while it stays the same.
    ob.data.vertices[0].co.z += 0.2
    ob.data.update()
    render_passes(tmp_path, "edited")
    render_passes(tmp_path, "edited_again")
    assert cache.counters["voxelisations"] == built + 1
    assert dict(worker.counters)["grid_uploads"] == after.get("grid_uploads", 0) + 1


def test_instances_share_one_grid(blank, tmp_path, monkeypatch):
    """Two linked duplicates of a mesh medium: two media, one voxelisation, one density array,
    the mesh's triangles read once (they were read and hashed per instance)."""
    builder = scene_builder
    builder.build(_scene("sphere"), str(tmp_path), settings=SETTINGS)
    ob = _add_medium("sphere", builder)
    twin = ob.copy()                       # shares the mesh data
    twin.location.x += 2.0
    bpy.context.scene.collection.objects.link(twin)
    cache = _mod("engine.mesh_volume").occupancy_cache
    cache.clear()
    built = cache.counters["voxelisations"]
    meshes, reads = _mod("blender.meshes"), []
    triangles = meshes.triangles
    monkeypatch.setattr(meshes, "triangles", lambda evaluated: reads.append(1) or triangles(evaluated))
    ex = _mod("blender.extract").extract(bpy.context.evaluated_depsgraph_get())
    monkeypatch.undo()
    assert len(ex.media) == 2 and ex.media[0].density is ex.media[1].density
    assert len(reads) == 2      # the twins' one mesh, and the ground
    assert cache.counters["voxelisations"] == built + 1
    shift = ex.media[1].index_to_world[:3, 3] - ex.media[0].index_to_world[:3, 3]
    np.testing.assert_allclose(shift, (2.0, 0.0, 0.0), atol=1e-6)
    worker = _mod("blender.render_worker").get_worker()
    uploads = dict(worker.counters).get("grid_uploads", 0)
    render_passes(tmp_path, "twins")
    assert dict(worker.counters)["grid_uploads"] == uploads + 1     # one texture for both
