"""What a farm reads in the log of a command-line render: a documented approximation (multiple
scattering at Volume Bounces) is Info, said once for the frame range, as is what Auto chose; a
clean render prints no line with "Warning" (Deadline's strict mode fails a task on one); a setting
the engine does not read stays a Warning; a long frame prints its progress as farm managers read it."""

import re

import bpy
from blender_helpers import smoke
from test_farm import _worker

from tfm_addon.blender import scene_builder


def _log(blank, tmp_path, edit=None) -> list[str]:
    tmp_path.mkdir(parents=True, exist_ok=True)
    scene_builder.build(smoke(width=32, height=24, n=16), str(tmp_path))
    scene = bpy.context.scene
    scene.tfm.samples = 1
    scene.frame_start, scene.frame_end = 1, 3
    scene.cycles.volume_bounces = 16
    if edit is not None:
        edit(scene)
    blend = str(tmp_path / "farm.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    (tmp_path / "out").mkdir()
    done = _worker(blend, 1, 3, str(tmp_path / "out"))
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert len(list((tmp_path / "out").iterdir())) == 3
    return (done.stdout + done.stderr).splitlines()


def test_an_approximation_is_info_once_per_frame_range_and_a_clean_render_warns_nothing(blank, tmp_path):
    lines = _log(blank, tmp_path)
    bounces = [line for line in lines if "multiple scattering approximated by" in line]
    assert len(bounces) == 1 and bounces[0].startswith("Info: Volume Bounces 16"), bounces
    assert len([line for line in lines if "Auto quality:" in line]) == 1, lines
    assert not [line for line in lines if "warning" in line.lower()], lines


def test_a_setting_not_read_stays_a_warning(blank, tmp_path):
    def panoramic(scene):
        scene.camera.data.type = 'PANO'
    lines = _log(blank, tmp_path, panoramic)
    warned = [line for line in lines if line.startswith("Warning:")]
    assert len(warned) == 1 and "anoramic" in warned[0], lines


# Deadline's Blender adaptor reads a frame's progress from lines this expression matches
# (deadline-cloud-for-blender, BlenderAdaptor._get_regex_callbacks: Cycles' form).
DEADLINE_PROGRESS = re.compile(r"^Fra:.*Sample\s(\d+)\/(\d+)$")


def test_a_long_frame_prints_its_progress_as_farm_managers_read_it(blank, tmp_path, monkeypatch):
    monkeypatch.setenv("TFM_PROGRESS_AFTER_S", "0")      # every frame counts as long here
    lines = _log(blank, tmp_path, lambda scene: setattr(scene.tfm, "samples", 16))
    seen = [DEADLINE_PROGRESS.match(line) for line in lines]
    progress = [(int(m.group(1)), int(m.group(2))) for m in seen if m]
    assert progress and all(n == 16 and 0 <= k <= 16 for k, n in progress), lines
    assert [line for line in lines if line.startswith("Fra:1 ")], lines


def _through_deadline(lines: list[str]):
    """``lines`` fed through Deadline Cloud's Blender adaptor's own log callbacks, in its strict
    mode: (the progress it reported, the error it would fail the task with, or None)."""
    import logging

    from deadline.blender_adaptor.BlenderAdaptor.adaptor import BlenderAdaptor
    from openjd.adaptor_runtime.app_handlers import RegexHandler

    adaptor = BlenderAdaptor({"strict_error_checking": True})
    seen = []
    adaptor.update_status = lambda progress=None, status_message=None: seen.append(progress)
    logger = logging.getLogger("tfm.deadline_adaptor_test")
    logger.propagate, logger.level = False, logging.INFO
    handler = RegexHandler(adaptor._get_regex_callbacks())
    logger.addHandler(handler)
    try:
        for line in lines:
            logger.info(line)
    finally:
        logger.removeHandler(handler)
    return seen, adaptor._exc_info


def test_deadline_s_adaptor_reads_the_progress_and_a_clean_render_trips_no_strict_failure(
        blank, tmp_path, monkeypatch):
    monkeypatch.setenv("TFM_PROGRESS_AFTER_S", "0")
    lines = _log(blank, tmp_path, lambda scene: setattr(scene.tfm, "samples", 16))
    progress, error = _through_deadline(lines)
    assert progress and all(0 <= p <= 100 for p in progress), progress
    assert error is None, error
    # a setting the engine does not read is a Warning: the adaptor's strict mode fails the task
    monkeypatch.delenv("TFM_PROGRESS_AFTER_S")
    bpy.ops.wm.read_homefile(use_empty=True)
    panoramic = _log(blank, tmp_path / "pano", lambda scene: setattr(scene.camera.data, "type", 'PANO'))
    _, error = _through_deadline(panoramic)
    assert error is not None and "anoramic" in str(error), error
