"""Writing and reading scene-linear float images as OpenEXR files."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .output import RenderOutput


def write_exr(path: str | Path, channels: dict[str, np.ndarray]) -> Path:
    """Write (h, w) float arrays (top row first) as 32-bit float channels, ZIP-compressed.
    Channel names follow EXR's layer convention, e.g. 'R', 'scattering.G'."""
    import OpenEXR

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    data = {name: np.ascontiguousarray(a, dtype=np.float32) for name, a in channels.items()}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, data) as f:
        f.write(str(path))
    return path


def read_exr(path: str | Path) -> dict[str, np.ndarray]:
    """Every channel of every part of an EXR file as a float32 (h, w) array, top row first.
    Channels of a multi-part file (Blender writes one part per pass) are named
    '<part name>.<channel>' unless the channel name already carries the layer."""
    import OpenEXR

    out = {}
    with OpenEXR.File(str(path), separate_channels=True) as f:
        parts = f.parts
        for part in parts:
            prefix = ""
            if len(parts) > 1:
                name = part.header.get("name", "")
                prefix = f"{name}." if name else ""
            for channel_name, channel in part.channels.items():
                key = channel_name if "." in channel_name or not prefix else prefix + channel_name
                out[key] = np.asarray(channel.pixels, dtype=np.float32)
    return out


def output_channels(output: RenderOutput) -> dict[str, np.ndarray]:
    """A render as EXR channels: R, G, B, A and '<pass>.R/G/B' for each pass."""
    ch = {c: output.combined[:, :, i] for i, c in enumerate("RGBA")}
    for name, image in output.passes.items():
        for i, c in enumerate("RGB"):
            ch[f"{name}.{c}"] = image[:, :, i]
    return ch


def write_output(path: str | Path, output: RenderOutput) -> Path:
    return write_exr(path, output_channels(output))
