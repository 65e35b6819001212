"""Errors the renderer raises to its host."""


class RendererError(RuntimeError):
    """Base class of the renderer's errors; the message is meant for the user."""


class GLUnavailableError(RendererError):
    """No OpenGL 3.3 context could be created."""


class RenderCancelled(RendererError):
    """The host asked the render to stop."""
