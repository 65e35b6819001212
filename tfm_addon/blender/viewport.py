"""The interactive viewport: change flags in, an image for a view out, drawn with ``gpu``.

``ViewportSession`` holds what survives between redraws and needs no GPU module, so background
tests drive it directly; ``draw_image`` is the only code that touches Blender's ``gpu``.
"""

from __future__ import annotations

import numpy as np

from ..engine.output import RenderOutput
from ..engine.scene import Camera
from .changes import Change, changes_from_depsgraph
from .extract import Extraction, extract
from .render_worker import get_worker


class ViewportSession:
    """One viewport's scene between redraws.

    ``update`` (from ``view_update``) turns depsgraph updates into change flags and re-reads only
    the flagged parts; ``render`` (from ``view_draw``) renders a view, re-rendering only when the
    view or the scene changed. Map reuse across views is the renderer's (by keys).
    """

    def __init__(self):
        self.extraction: Extraction | None = None
        self.last_changes = Change.NONE
        self.renders = 0
        self._image: RenderOutput | None = None
        self._image_key = None
        self._generation = 0

    def update(self, depsgraph, changes: Change | None = None) -> Change:
        """Re-read what changed; return the flags used."""
        if self.extraction is None:
            changes = Change.ALL
            self.extraction = extract(depsgraph)
            self._generation += 1
        else:
            if changes is None:
                changes = changes_from_depsgraph(depsgraph, self.extraction.medium_sources)
            parts = changes & ~Change.CAMERA  # the viewport's camera is the view
            if parts:
                self.extraction = extract(depsgraph, parts=parts, previous=self.extraction)
                self._generation += 1
        self.last_changes = changes
        return changes

    def render(self, camera: Camera) -> RenderOutput:
        """The image for ``camera``; the previous one when neither it nor the scene changed."""
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

    @property
    def warnings(self) -> list[str]:
        return self.extraction.all_warnings if self.extraction else []


def view_size(region, scale: float) -> tuple[int, int]:
    return max(1, int(region.width * scale)), max(1, int(region.height * scale))


class DrawTexture:
    """An RGBA float image uploaded as a GPUTexture; ``gpu`` is imported here, lazily."""

    def __init__(self, image: np.ndarray):
        import gpu

        h, w, _ = image.shape
        pixels = np.ascontiguousarray(np.nan_to_num(image[::-1], posinf=6.0e4), dtype=np.float32)
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
