"""The TFM renderer: single scattering in participating media by transmittance function maps.

Plain Python (numpy, moderngl, OpenEXR): it never imports Blender.
"""

from .errors import GLUnavailableError, RenderCancelled, RendererError
from .output import RenderOutput
from .renderer import Renderer
from .scene import Camera, Light, Medium, Mesh, RenderSettings, Scene

__all__ = ["Camera", "GLUnavailableError", "Medium", "Mesh", "RenderCancelled", "RenderOutput",
           "RenderSettings", "Renderer", "RendererError", "Scene", "Light"]
