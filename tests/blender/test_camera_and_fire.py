"""The camera as Cycles renders it (depth of field, motion blur, camera types) and a fire lighting
the ground, beyond the conformance rows (dof, dof_blades, motion_blur_volume, motion_blur_camera,
fire_lights_ground): what the report says, and the ground under the fire against Cycles."""

import dataclasses
import importlib

import bpy
import numpy as np
import pytest
from blender_helpers import MODULE

from tfm_addon.bench import conformance


def _mod(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.blender.{name}")


def test_the_fire_lights_the_ground_within_ten_percent_of_cycles(blank, tmp_path):
    row = conformance.ROW_BY_ID["fire_lights_ground"]
    cycles, _ = conformance.load_reference(row.id)
    result = conformance.render_tfm(row, str(tmp_path))
    ground = slice(int(cycles.shape[0] * 0.75), None)      # the rows below the fire: ground only
    ratio = result.image[ground, :, :3].sum(axis=(0, 1)) / cycles[ground, :, :3].sum(axis=(0, 1))
    print(f"ground under the fire: TFM / Cycles {np.round(ratio, 3)}; report {result.messages}")
    assert float(cycles[ground, :, 0].mean()) > 1e-3       # Cycles lights it
    assert np.all(np.abs(ratio - 1.0) <= 0.10)
    assert any("lights the surfaces from" in m for m in result.messages)


def test_unsupported_cameras_and_orthographic_depth_of_field_are_said(blank):
    bpy.ops.object.camera_add()
    cam = bpy.context.object
    bpy.context.scene.camera = cam
    extract = _mod("extract").extract
    cam.data.type = 'PANO'
    lines = extract(bpy.context.evaluated_depsgraph_get()).all_warnings
    assert any("panoramic cameras are not supported" in w for w in lines), lines
    cam.data.type = 'ORTHO'
    cam.data.dof.use_dof = True
    lines = extract(bpy.context.evaluated_depsgraph_get()).all_warnings
    assert any("depth of field of an orthographic camera is not rendered" in w for w in lines), lines
    cam.data.type = 'PERSP'
    ex = extract(bpy.context.evaluated_depsgraph_get())
    lens = ex.camera.aperture
    assert lens is not None and lens.radius_m == pytest.approx(0.05 / (2 * cam.data.dof.aperture_fstop))


def test_a_volumes_velocity_grid_is_named_when_motion_blur_is_on(blank, tmp_path):
    grids = {"density": conformance.density_grid(8), "velocity": np.ones((8, 8, 8, 3), np.float32)}
    conformance.volume_object(str(tmp_path), grids=grids)
    notes = _mod("motion").velocity_notes(bpy.context.evaluated_depsgraph_get())
    assert notes == ["Volume 'Smoke': its velocity grid 'velocity' is not rendered; motion blur moves "
                     "the volume with its object only"], notes


def test_a_viewport_through_the_camera_shows_its_depth_of_field(blank):
    from types import SimpleNamespace

    bpy.ops.object.camera_add()
    cam = bpy.context.object
    bpy.context.scene.camera = cam
    cam.data.dof.use_dof, cam.data.dof.focus_distance = True, 2.5
    lens = _mod("camera").camera_view_aperture
    dg = bpy.context.evaluated_depsgraph_get()
    seen = lens(SimpleNamespace(view_perspective='CAMERA'), bpy.context.scene, dg)
    assert seen is not None and seen.focus_m == pytest.approx(2.5)
    assert lens(SimpleNamespace(view_perspective='PERSP'), bpy.context.scene, dg) is None


def test_an_object_cycles_does_not_blur_stays_sharp_and_the_frame_is_restored(blank, tmp_path):
    row = conformance.ROW_BY_ID["motion_blur_volume"]
    build = row.build

    def still(tmpdir, blur_scene: bool):
        build(tmpdir)
        bpy.context.scene.objects["Smoke"].cycles.use_motion_blur = False   # Object ▸ Motion Blur
        bpy.context.scene.render.use_motion_blur = blur_scene

    images = []
    for blur_scene in (True, False):
        row.build = lambda tmpdir, b=blur_scene: still(tmpdir, b)
        try:
            images.append(conformance.render_tfm(row, str(tmp_path / str(blur_scene))).image)
        finally:
            row.build = build
        if blur_scene:    # the shutter was read at sub-frames: the frame is as it was
            scene = bpy.context.scene
            x = scene.objects["Smoke"].matrix_world.translation.x
            assert (scene.frame_current, scene.frame_subframe) == (1, 0.0)
            scene.frame_set(1)
            assert scene.objects["Smoke"].matrix_world.translation.x == pytest.approx(x)
            assert _mod("motion").shutter_window(scene.render, 1.0) == (0.75, 1.25)
    assert np.abs(images[0] - images[1]).max() < 1e-6


def test_the_viewport_through_the_camera_converges_to_the_final_renders_depth_of_field(blank, tmp_path):
    import time
    from types import SimpleNamespace

    row = conformance.ROW_BY_ID["dof"]
    final = conformance.render_tfm(row, str(tmp_path), samples=6).image
    dg = bpy.context.evaluated_depsgraph_get()
    ob = bpy.context.scene.camera.evaluated_get(dg)
    camera_module = _mod("camera")
    view = np.linalg.inv(camera_module.without_scale(ob.matrix_world))
    width, height = final.shape[1], final.shape[0]
    projection = np.array(ob.calc_matrix_camera(dg, x=width, y=height))
    camera = camera_module.camera_from_view(view, projection, width, height)
    lens = camera_module.camera_view_aperture(SimpleNamespace(view_perspective='CAMERA'),
                                              bpy.context.scene, dg)
    camera = dataclasses.replace(camera, aperture=lens)
    session = _mod("viewport").ViewportSession()
    try:
        session.update(dg)
        assert session.request(camera, 6)
        end = time.monotonic() + 60.0
        frame = None
        while time.monotonic() < end:
            frame = session.frame()
            if frame is not None and frame.samples == 6 and session.view.state == "idle":
                break
            time.sleep(0.01)
        assert frame is not None and frame.samples == 6
        assert float(np.abs(frame.image - final).max()) <= 1e-4
        pinhole = session.render(dataclasses.replace(camera, aperture=None)).combined
        assert float(np.abs(pinhole - final).max()) > 0.01      # the lens blurred it
    finally:
        session.close()
