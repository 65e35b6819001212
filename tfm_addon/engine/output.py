"""What a render returns."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class RenderOutput:
    """A rendered frame, scene-linear radiance, numpy arrays with the top row first.

    ``combined``: (h, w, 4) float32, premultiplied RGBA. Transparent film: RGB is scattering +
    surfaces; alpha is 1 where a solid is seen, else 1 - mean(transmittance). Opaque film: alpha 1
    and, where no solid is seen, the world's radiance times the transmittance added to RGB
    (holdouts keep the transparent film's alpha and no world).
    ``passes``: 'scattering' (light scattered toward the camera, spot lights and ambient),
    'surfaces' (radiance of the solids, already attenuated by the medium in front of them) and
    'transmittance' (view-ray transmittance to the solid or through the medium), each (h, w, 3).
    ``warnings``: one line per problem the user should hear about.
    ``timings_s``: seconds spent per stage.
    ``chosen``: the quality the frame rendered with (view_steps, light_steps, coefficients and the
    largest transmittance map side, tfm_side), for the render report under Auto.
    """

    combined: np.ndarray
    passes: dict[str, np.ndarray] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    timings_s: dict[str, float] = field(default_factory=dict)
    chosen: dict = field(default_factory=dict)

    @property
    def rgb(self) -> np.ndarray:
        return self.combined[:, :, :3]

    @staticmethod
    def compose(scattering: np.ndarray, surfaces: np.ndarray, transmittance: np.ndarray,
                surface_mask: np.ndarray, world=None, background_mask: np.ndarray | None = None,
                **kwargs) -> RenderOutput:
        """Assemble the combined image from its passes (all (h, w, 3) except the (h, w) masks).
        ``world`` None: transparent film; else the RGB radiance (or an (h, w, 3) image of it) seen,
        through the medium, at the
        pixels of ``background_mask`` (no solid seen; default: not ``surface_mask``), with alpha 1
        everywhere but at holdouts (neither mask)."""
        h, w = surface_mask.shape
        combined = np.empty((h, w, 4), dtype=np.float32)
        combined[:, :, :3] = scattering + surfaces
        combined[:, :, 3] = np.where(surface_mask, 1.0, 1.0 - transmittance.mean(axis=2))
        if world is not None:
            bg = ~surface_mask if background_mask is None else background_mask
            combined[:, :, :3] += np.where(bg[..., None], transmittance * np.asarray(world, np.float64), 0.0)
            combined[:, :, 3] = np.where(bg | surface_mask, 1.0, combined[:, :, 3])
        passes = {"scattering": np.asarray(scattering, np.float32),
                  "surfaces": np.asarray(surfaces, np.float32),
                  "transmittance": np.asarray(transmittance, np.float32)}
        return RenderOutput(combined=combined, passes=passes, **kwargs)
