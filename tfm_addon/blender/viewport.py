"""The interactive viewport: change flags in, a progressive image for a view out, drawn with ``gpu``.

``ViewportSession`` holds what survives between redraws and needs no GPU module, so background
tests drive it directly. On Blender's thread it only reads the depsgraph (what changed) and posts
requests to the progressive view (engine.progressive); the GL thread renders a coarse image, the
full one, then accumulates samples. A ``bpy.app.timers`` poll asks for a redraw when a frame is
ready. ``DrawTexture`` is the only code that touches Blender's ``gpu``.
"""

from __future__ import annotations

import time

import numpy as np

from ..engine.output import RenderOutput
from ..engine.progressive import ProgressiveView, upload_pixels
from ..engine.scene import Camera
from ..engine.worker import WorkerClosed
from .changes import Change, changes_from_depsgraph
from .extract import Extraction, WalkCache, extract, scene_changes, scene_state
from .render_worker import get_worker

POLL_S = 0.03  # how often the timer looks for a finished frame


class ViewportSession:
    """One viewport's scene between redraws.

    ``update`` (from ``view_update``) turns depsgraph updates into change flags and re-reads only
    the flagged parts; ``request`` (from ``view_draw``) posts the view to the progressive view,
    which renders off Blender's thread; ``frame`` is the newest finished image. Map reuse across
    views is the renderer's (by keys). ``callback_s`` is the longest time ``update`` or
    ``request`` held the calling thread.
    """

    def __init__(self):
        self.extraction: Extraction | None = None
        self.last_changes = Change.NONE
        self.renders = 0
        self.callback_s = 0.0
        self.redraw = None          # set by the engine: asks Blender to redraw (main thread only)
        self._image: RenderOutput | None = None
        self._image_key = None
        self._generation = 0
        self._view: ProgressiveView | None = None
        self.kept = WalkCache()     # per object: triangles, generated grids, last Mesh values
        self._scene_state: dict | None = None
        self.update_s = 0.0         # the last update's time on the calling thread

    def update(self, depsgraph, changes: Change | None = None) -> Change:
        """Re-read what changed; return the flags used. Without ``changes`` they come from the
        depsgraph's updates, which also say whose geometry changed: only those objects' triangles
        and grids are read again, a moved object is placed by its new matrix. A change that
        renders nothing differently (a selection) leaves the image, converged or not, as it is."""
        t0 = time.perf_counter()
        if self.extraction is None:
            changes = Change.ALL
            self.kept.clear()
            self.extraction = extract(depsgraph, kept=self.kept)
            self._scene_state = scene_state(depsgraph)
            self._generation += 1
        else:
            if changes is None:
                changes = self._changes(depsgraph)
            else:      # flags worked out elsewhere: whose geometry changed is not known
                if changes & (Change.SOLIDS | Change.MEDIUM):
                    self.kept.clear()
                self._scene_state = scene_state(depsgraph)
            parts = changes & ~Change.CAMERA  # the viewport's camera is the view
            if parts:
                self.extraction = extract(depsgraph, parts=parts, previous=self.extraction,
                                          kept=self.kept)
                self._generation += 1
        self.last_changes = changes
        self.update_s = time.perf_counter() - t0
        self.callback_s = max(self.callback_s, self.update_s)
        return changes

    def _changes(self, depsgraph) -> Change:
        """The flags of the depsgraph's updates; forgets the kept geometry of the objects and
        data whose geometry changed. A Scene update flags only what its settings, world, frame
        or visible objects changed (compared with the state after the last update)."""
        stale, scene_updated = set(), False
        for update in depsgraph.updates:
            ident = update.id
            if ident.id_type == 'SCENE':
                scene_updated = True
            elif update.is_updated_geometry:
                stale.add(ident.name)
        scene = Change.NONE
        s = depsgraph.scene
        if self._scene_state is None or \
                (s.frame_current, float(s.frame_subframe)) != self._scene_state["frame"]:
            scene_updated = True      # a frame change may come without the Scene's update
        if scene_updated:
            state = scene_state(depsgraph)
            scene = scene_changes(self._scene_state, state)
            if self._scene_state is None or state["frame"] != self._scene_state["frame"]:
                self.kept.forget_grids()
            self._scene_state = state
        self.kept.forget(stale)
        return scene | changes_from_depsgraph(depsgraph, self.extraction.medium_sources, scene=scene)

    @property
    def view(self) -> ProgressiveView:
        """This viewport's progressive view, on a worker slot and cache client of its own (two
        Rendered viewports on one slot superseded each other: one never showed an edit)."""
        worker = get_worker()
        if self._view is None or self._view.worker is not worker:
            self._view = ProgressiveView(worker, slot=f"viewport {id(self):x}")
        return self._view

    def request(self, camera: Camera, samples: int) -> bool:
        """Post ``camera``'s view up to ``samples`` (nothing when it is the current request)."""
        if self.extraction is None:
            raise RuntimeError("update() must run before request()")
        t0 = time.perf_counter()
        settings = self.extraction.settings
        posted = self.view.request((self._generation, camera.key, settings), self.extraction.scene(camera),
                                   settings, samples)
        self.callback_s = max(self.callback_s, time.perf_counter() - t0)
        return posted

    def frame(self):
        return None if self._view is None else self._view.frame()

    @property
    def status(self) -> str:
        return "" if self._view is None else self._view.status

    def render(self, camera: Camera) -> RenderOutput:
        """The pixel-centre image for ``camera``, rendered now (waits: for scripts and tests);
        the previous one when neither the view nor the scene changed."""
        if self.extraction is None:
            raise RuntimeError("update() must run before render()")
        key = (camera.key, self._generation)
        if key != self._image_key:
            scene, settings = self.extraction.scene(camera), self.extraction.settings
            # The viewport shows the combined image only: skip reading back the passes.
            self._image = get_worker().call(lambda r: r.render(scene, settings, passes=False,
                                                               client="viewport"))
            self._image_key = key
            self.renders += 1
        return self._image

    def close(self) -> None:
        """Stop refining, stop being polled, and release the maps only this view kept (on the
        GL thread, without waiting)."""
        _polled.pop(id(self), None)
        view = self._view
        if view is not None:
            view.cancel()
            try:
                view.worker.submit(lambda r, job: r.forget_client(view.client))
            except WorkerClosed:
                pass

    @property
    def warnings(self) -> list[str]:
        return self.extraction.all_warnings if self.extraction else []


# The sessions the timer polls for finished frames, by id.
_polled: dict[int, ViewportSession] = {}


def _poll():
    """bpy.app.timers callback (Blender's main thread): redraw the viewports with a new frame."""
    for key, session in list(_polled.items()):
        view = session._view
        if view is None or not view.take_redraw() or session.redraw is None:
            continue
        try:
            session.redraw()
        except ReferenceError:  # Blender freed the engine: forget its session
            _polled.pop(key, None)
            session.close()
    return POLL_S if _polled else None


def start_polling(session: ViewportSession) -> None:
    import bpy

    _polled[id(session)] = session
    if not bpy.app.timers.is_registered(_poll):
        bpy.app.timers.register(_poll, first_interval=POLL_S, persistent=True)


def stop_polling() -> None:
    """Forget every session and remove the timer (the add-on is being disabled)."""
    import bpy

    for session in list(_polled.values()):
        session.close()
    _polled.clear()
    if bpy.app.timers.is_registered(_poll):
        bpy.app.timers.unregister(_poll)


def is_polling() -> bool:
    import bpy

    return bpy.app.timers.is_registered(_poll)


def view_size(region, scale: float) -> tuple[int, int]:
    return max(1, int(region.width * scale)), max(1, int(region.height * scale))


class DrawTexture:
    """An RGBA float image (top row first) uploaded as a GPUTexture; ``pixels``, when given, is
    that image already prepared (progressive.upload_pixels, on the GL thread). ``gpu`` is imported
    here, lazily."""

    def __init__(self, image: np.ndarray, pixels: np.ndarray | None = None):
        import gpu

        h, w, _ = image.shape
        if pixels is None:
            pixels = upload_pixels(image)
        buffer = gpu.types.Buffer('FLOAT', pixels.size, pixels.ravel())
        self.texture = gpu.types.GPUTexture((w, h), format='RGBA32F', data=buffer)

    def draw(self, engine, scene, width: int, height: int) -> None:
        import gpu
        from gpu_extras.presets import draw_texture_2d

        gpu.state.blend_set('ALPHA_PREMULT')
        engine.bind_display_space_shader(scene)
        draw_texture_2d(self.texture, (0, 0), width, height)
        engine.unbind_display_space_shader()
        gpu.state.blend_set('NONE')
