"""The RenderEngine Blender talks to: every callback forwards to the module that does the work."""

import dataclasses
import traceback

import bpy

from . import final_render, viewport
from .camera import camera_from_view, camera_view_aperture
from .viewport import DrawTexture, ViewportSession, view_size


class TFMRenderEngine(bpy.types.RenderEngine):
    bl_idname = 'TFM'
    bl_label = "TFM"
    # What Blender should expect of this engine (docs/blender.md, "Engine flags"):
    bl_use_preview = True                # renders material, light and world previews
    bl_use_postprocess = True            # Blender composites and sequences the result
    bl_use_shading_nodes_custom = False  # reads Blender's shader nodes: keep the Shader Editor
    bl_use_eevee_viewport = True         # Material Preview is EEVEE's look-dev, Rendered is TFM
    bl_use_gpu_context = False           # renders in its own OpenGL context on its own thread
    bl_use_image_save = True             # Blender writes the frames of an animation
    bl_use_custom_freestyle = False      # Freestyle strokes are Blender's, drawn over the result
    bl_use_spherical_stereo = False      # no panoramic stereo cameras
    bl_use_stereo_viewport = False       # one view in the viewport
    bl_use_materialx = False             # not a Hydra delegate

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._session = None
        self._texture = None
        self._texture_of = None
        self._viewport_error = None

    def render(self, depsgraph):
        if not self.is_preview:   # background Blender: SIGINT/SIGTERM stop the render job cleanly
            final_render.guard_signals()
        final_render.render(self, depsgraph)

    def update_render_passes(self, scene=None, renderlayer=None):
        final_render.register_passes(self, scene, renderlayer)

    def view_update(self, context, depsgraph):
        # Blender's thread: read what changed; the image is rendered on the GL thread.
        try:
            if self._session is None:
                self._session = ViewportSession()
                self._session.redraw = self.tag_redraw
                viewport.start_polling(self._session)
            self._session.update(depsgraph)
        except Exception as ex:
            self._viewport_failed(ex)

    def view_draw(self, context, depsgraph):
        # Post the view (latest wins) and draw the newest finished frame; never waits.
        session = self._session
        if session is None or session.extraction is None:
            return
        region, rv3d, tfm = context.region, context.region_data, context.scene.tfm
        width, height = view_size(region, tfm.viewport_scale)
        try:
            camera = camera_from_view(rv3d.view_matrix, rv3d.window_matrix, width, height)
            lens = camera_view_aperture(rv3d, context.scene, depsgraph)
            if lens is not None and camera.projection == 'PERSP':
                camera = dataclasses.replace(camera, aperture=lens)
            session.request(camera, tfm.viewport_samples)
        except Exception as ex:
            self._viewport_failed(ex)
            return
        self._viewport_error = None
        frame = session.frame()
        if frame is not None:
            if self._texture_of is not frame:
                self._texture, self._texture_of = DrawTexture(frame.image, frame.pixels), frame
            self._texture.draw(self, context.scene, region.width, region.height)
        self.update_stats("", f"TFM: {session.status}" if session.status else "TFM")

    def __del__(self):
        try:
            session = self._session
        except (AttributeError, ReferenceError):
            return
        if session is not None:
            session.close()

    def _viewport_failed(self, ex):
        message = f"TFM viewport: {ex}"
        if message != self._viewport_error:
            self._viewport_error = message
            traceback.print_exc()
        self.update_stats("", message)


classes = (TFMRenderEngine,)
