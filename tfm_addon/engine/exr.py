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
    """Every channel of an EXR file as a float32 (h, w) array, top row first."""
    import OpenEXR

    out = {}
    with OpenEXR.File(str(path), separate_channels=True) as f:
        for name, channel in f.channels().items():
            out[name] = np.asarray(channel.pixels, dtype=np.float32)
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
