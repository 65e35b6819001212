"""The numpy reference's images, stored by scene content (as the Cycles images are).

``render_reference`` has the signature of :func:`tfm_addon.engine.reference.render_reference`. It
looks the image up in ``tests/data/reference/<key>.npz``, the key a digest of everything the
reference reads: the scene's dataclasses (fields left at their defaults are left out, so a new
field does not change the key of a scene that does not set it), the settings it reads, the march's
step counts and the source of the reference renderer itself. A missing image fails the test with
the command that makes it; with ``TFM_STORE_REFERENCES=1`` the reference renders and stores it.

The reference's own tests (``tests/test_reference.py``) call the renderer itself.
"""

from __future__ import annotations

import dataclasses
import enum
import hashlib
import os
from pathlib import Path

import numpy as np
import pytest

from tfm_addon.engine import reference
from tfm_addon.engine.output import RenderOutput

STORE = Path(__file__).resolve().parent / "data" / "reference"
STORE_ENV = "TFM_STORE_REFERENCES"
_CODE = [Path(reference.__file__), Path(reference.__file__).with_name("boxes.py")]


def _digest(value, out: list) -> None:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        out.append(type(value).__name__)
        for f in dataclasses.fields(value):
            v = getattr(value, f.name)
            default = (f.default if f.default is not dataclasses.MISSING
                       else f.default_factory() if f.default_factory is not dataclasses.MISSING
                       else dataclasses.MISSING)
            if default is not dataclasses.MISSING and _same(v, default):
                continue
            out.append(f.name)
            _digest(v, out)
    elif isinstance(value, np.ndarray):
        a = np.ascontiguousarray(value)
        out.append(f"array{a.dtype.str}{a.shape}{hashlib.sha1(a.tobytes()).hexdigest()}")
    elif isinstance(value, (list, tuple)):
        out.append(f"[{len(value)}")
        for v in value:
            _digest(v, out)
        out.append("]")
    elif isinstance(value, dict):
        out.append(f"{{{len(value)}")
        for k in sorted(value, key=repr):
            out.append(repr(k))
            _digest(value[k], out)
        out.append("}")
    elif isinstance(value, (bool, int, float, str, bytes, type(None), enum.Enum, np.generic)):
        out.append(repr(value))
    else:
        text = repr(value)
        if " at 0x" in text:
            raise TypeError(f"no stable digest for {type(value).__name__}: {text[:80]}")
        out.append(text)


def _same(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return (isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.shape == b.shape
                and a.dtype == b.dtype and bool(np.array_equal(a, b)))
    try:
        return type(a) is type(b) and bool(a == b)
    except Exception:
        return False


def key(scene, settings=None, tag: str = "", **steps) -> str:
    """The digest that names a reference image (``tag`` names a variant of the reference that the
    test made, e.g. with a part of it patched out)."""
    parts: list = [tag]
    for path in _CODE:
        parts.append(hashlib.sha1(path.read_bytes()).hexdigest())
    _digest(scene, parts)
    read = None if settings is None else (settings.ambient, settings.film_transparent, settings.world_light)
    _digest(read, parts)
    _digest(dict(steps), parts)
    return hashlib.sha1("\n".join(parts).encode()).hexdigest()[:20]


def render_reference(scene, settings=None, *, tag: str = "", **steps) -> RenderOutput:
    """The reference's image of ``scene``, from the store (see the module's docstring)."""
    name = key(scene, settings, tag, **steps)
    path = STORE / f"{name}.npz"
    if path.exists():
        with np.load(path) as f:
            passes = {k[len("pass_"):]: f[k] for k in f.files if k.startswith("pass_")}
            return RenderOutput(combined=f["combined"], passes=passes,
                                timings_s={"reference": float(f["seconds"])})
    if os.environ.get(STORE_ENV) != "1":
        pytest.fail(f"no stored numpy reference {path.relative_to(STORE.parents[2])}: make it with "
                    f"`{STORE_ENV}=1 .venv/bin/python -m pytest <this test>` and commit the file",
                    pytrace=False)
    out = reference.render_reference(scene, settings, **steps)
    STORE.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, combined=out.combined, seconds=out.timings_s.get("reference", 0.0),
                        **{f"pass_{k}": v for k, v in out.passes.items()})
    return out
