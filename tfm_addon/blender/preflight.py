"""The pre-flight check of a .blend on a render-farm worker, before any frame renders.

``check(scene)`` lists what would make the scene's frames render wrong on this machine: the render
engine not TFM, a file the scene reads missing (a Volume's .vdb or every frame of its sequence in
the frame range, a fluid domain's baked cache for those frames, an image (each UDIM tile, each
frame of a sequence), a linked library), each with the absolute path tried (images in the
renderer's message form, files.py), and OpenGL not available (else its vendor and renderer are named).
The operator ``bpy.ops.tfm.preflight()`` prints the lines and, where there are problems, reports an
error, which a script called from the command line turns into a non-zero exit status
(``--python-exit-code``); docs/blender.md, "Render farms".
"""

from __future__ import annotations

import dataclasses
import os

import bpy

from . import files
from .fluid import cache_file, data_frame, domain_modifier, noise_file

ENGINE_ID = 'TFM'
GL_TIMEOUT_S = 60.0
VOLUME_FRAME_NONE = None     # a frame outside a Clip sequence: no file is read


@dataclasses.dataclass
class Preflight:
    """What the check found: ``problems`` (each a line naming what and the path tried) and
    ``notes`` (what was checked and found, for the log)."""

    problems: list[str] = dataclasses.field(default_factory=list)
    notes: list[str] = dataclasses.field(default_factory=list)

    def lines(self) -> list[str]:
        return ([f"TFM preflight: {n}" for n in self.notes]
                + [f"TFM preflight: PROBLEM: {p}" for p in self.problems]
                + [f"TFM preflight: {len(self.problems)} problem(s)" if self.problems
                   else "TFM preflight: OK"])


def sequence_file_frame(frame: int, start: int, duration: int, offset: int, mode: str) -> int | None:
    """The frame number of a volume sequence's file read at scene ``frame`` (Blender's
    ``volume_sequence_frame``), None where the sequence reads no file (Clip outside its frames)."""
    if duration <= 0:
        return None
    f = frame - start + 1
    if mode == 'CLIP':
        if f < 1 or f > duration:
            return None
    elif mode == 'EXTEND':
        f = min(max(f, 1), duration)
    elif mode == 'REPEAT':
        f %= duration
        if f == 0:
            f = duration
    elif mode == 'PING_PONG':
        period = duration * 2 - 2
        if period <= 0:
            f = 1
        else:
            f %= period
            if f == 0:
                f = period
            if f > duration:
                f = duration * 2 - f
    return f + offset


def _abspath(path: str, id_data) -> str:
    return files.abspath(path, id_data)


def _render_objects(scene):
    """The objects a final render of ``scene`` may see: the scene's objects not hidden from
    renders and those of the collections they instance (each object once)."""
    seen, stack = set(), [ob for ob in scene.objects]
    while stack:
        ob = stack.pop()
        if ob.name_full in seen or ob.hide_render:
            continue
        seen.add(ob.name_full)
        yield ob
        if ob.instance_type == 'COLLECTION' and ob.instance_collection is not None:
            stack.extend(ob.instance_collection.all_objects)


def _frames(scene) -> range:
    return range(scene.frame_start, scene.frame_end + 1, max(1, scene.frame_step))


def _check_volume(volume, label: str, frames: range, out: Preflight) -> None:
    if volume.packed_file is not None or not volume.filepath:
        return                                   # packed or generated: nothing to find
    path = _abspath(volume.filepath, volume)
    if not volume.is_sequence:
        if not os.path.isfile(path):
            out.problems.append(f"Volume '{label}': '{path}' not found")
        return
    missing = []
    wanted = {sequence_file_frame(f, volume.frame_start, volume.frame_duration, volume.frame_offset,
                                  volume.sequence_mode) for f in frames} - {VOLUME_FRAME_NONE}
    for n in sorted(wanted):
        tried = files.frame_path(path, n)
        if not os.path.isfile(tried):
            missing.append(tried)
    if missing:
        out.problems.append(f"Volume '{label}': {len(missing)} of the {len(wanted)} files the frames "
                            f"{frames.start}-{frames.stop - 1} read are missing, the first "
                            f"'{missing[0]}'")


def _check_fluid(ob, frames: range, out: Preflight) -> None:
    modifier = domain_modifier(ob, render=True)
    if modifier is None:
        return
    settings = modifier.domain_settings
    directory = _abspath(settings.cache_directory, ob)
    if settings.cache_data_format != 'OPENVDB':
        out.problems.append(f"Fluid domain '{ob.name}': cache format {settings.cache_data_format} is "
                            f"not read (only OpenVDB); cache folder '{directory}'")
        return
    baked = range(settings.cache_frame_start, settings.cache_frame_end + 1)
    cached = sorted({data_frame(settings, f) for f in frames} & set(baked))
    missing = [cache_file(directory, c) for c in cached if not os.path.isfile(cache_file(directory, c))]
    if settings.use_noise:
        missing += [noise_file(directory, c) for c in cached if not os.path.isfile(noise_file(directory, c))]
    if missing:
        out.problems.append(f"Fluid domain '{ob.name}': {len(missing)} cache files of the frames "
                            f"{frames.start}-{frames.stop - 1} are missing in '{directory}', the first "
                            f"'{missing[0]}'")


def _image_users() -> dict:
    """Image name -> [(owner as the renderer's report names it, the node's image user or None)]:
    the nodes of materials, worlds and node groups, and the lights' projected textures."""
    users: dict = {}
    trees = ([(f"Material '{m.name}'", m.node_tree) for m in bpy.data.materials]
             + [(f"World '{w.name}'", w.node_tree) for w in bpy.data.worlds]
             + [(f"Node group '{g.name}'", g) for g in bpy.data.node_groups])
    for owner, tree in trees:
        for node in getattr(tree, "nodes", ()):
            image = getattr(node, "image", None)
            if isinstance(image, bpy.types.Image):
                users.setdefault(image.name_full, []).append(
                    (f"{owner}: node '{node.name}'", getattr(node, "image_user", None)))
    for light in bpy.data.lights:
        gobo = getattr(getattr(light, "tfm", None), "gobo", None)
        if gobo is not None:
            users.setdefault(gobo.name_full, []).append((f"Light '{light.name}': its projected texture",
                                                         None))
    return users


def _check_images(frames: range, out: Preflight) -> None:
    """Every image a frame of the range reads (files.py: packed and generated images read no
    file, a UDIM image each tile's, a sequence the frames'), in the renderer's message form."""
    users = _image_users()
    for image in bpy.data.images:
        if image.users == 0:
            continue
        owner, image_user = (users.get(image.name_full) or [("", None)])[0]
        if image.source == 'SEQUENCE' and image_user is not None:
            wanted = sorted({p for f in frames for p in files.image_files(image, f, image_user)})
            gone = tuple(p for p in wanted if not os.path.isfile(p))
            missing = files.Missing(image.filepath, gone, len(wanted)) if gone else None
        else:
            missing = files.missing_image(image)
        if missing is not None:
            out.problems.append(files.image_message(owner, image, missing))


def _check_libraries(out: Preflight) -> None:
    for library in bpy.data.libraries:
        path = _abspath(library.filepath, library)
        if not os.path.isfile(path):
            out.problems.append(f"Library '{library.name}': '{path}' not found")


def _check_gl(out: Preflight) -> None:
    from .render_worker import get_worker

    try:
        out.notes.append("OpenGL " + get_worker().call(lambda r: r.gl.describe(), timeout_s=GL_TIMEOUT_S))
    except Exception as ex:
        out.problems.append(f"OpenGL is not available: {type(ex).__name__}: {ex}")


def check(scene, gl: bool = True) -> Preflight:
    """Everything a final render of ``scene``'s frame range needs on this machine (module doc)."""
    from .final_render import addon_version

    out = Preflight()
    frames = _frames(scene)
    out.notes.append(f"add-on {addon_version()}, scene '{scene.name}', "
                     f"frames {frames.start}-{frames.stop - 1}")
    if scene.render.engine != ENGINE_ID:
        out.problems.append(f"Scene '{scene.name}' renders with {scene.render.engine}, not TFM "
                            f"(Render Properties > Render Engine)")
    for ob in _render_objects(scene):
        if ob.type == 'VOLUME' and ob.data is not None:
            _check_volume(ob.data, ob.name, frames, out)
        elif ob.type == 'MESH':
            _check_fluid(ob, frames, out)
    _check_images(frames, out)
    _check_libraries(out)
    if gl:
        _check_gl(out)
    return out


class TFM_OT_preflight(bpy.types.Operator):
    """Check that this machine can render the scene's frames with TFM: files found, OpenGL
    available, TFM the render engine"""

    bl_idname = "tfm.preflight"
    bl_label = "TFM Pre-flight Check"

    def execute(self, context):
        result = check(context.scene)
        for line in result.lines():
            print(line, flush=True)
        if result.problems:
            self.report({'ERROR'}, "TFM preflight: " + "; ".join(result.problems))
            return {'CANCELLED'}
        self.report({'INFO'}, "TFM preflight: OK")
        return {'FINISHED'}


classes = (TFM_OT_preflight,)
