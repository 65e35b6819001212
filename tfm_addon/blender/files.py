"""Every file a frame reads, resolved in one step, with one message form for one that is missing.

``abspath`` makes a path as written absolute the way Blender does: ``//`` relative to the .blend,
or to the linked library the data-block comes from. ``image_files`` lists the files an image reads
for a frame: none for a packed or generated image (present, never missing), the file of a
single-file image or movie, each tile's file of a UDIM image (its ``<UDIM>`` / ``<UVTILE>``
token), the frame's file of an image sequence (Blender's image-user frame rule).
``missing_image`` says what is missing of an image, and ``missing_message`` how it is said,
by the renderer's report and by the pre-flight check alike:

    <owner> reads <what> '<name>': file '<path as written>' not found at '<absolute path tried>';
    rendering without it: <what renders instead>

where the owner is the node and the material, world or light it belongs to (the caller's report
puts "Material 'M': " or "World 'W': " before the node). A frame that
renders without a file's content says "rendering without it", which strict mode
(final_render.missing_data) turns into a failed frame. An image renders as Cycles renders a
missing one: its missing-texture pink, ``MISSING_PINK`` (1, 0, 1) (measured for Blender 5.0.1's
Cycles: a surface's Image Texture and the world's Environment Texture alike).
"""

from __future__ import annotations

import dataclasses
import os
import re

MISSING_PINK = (1.0, 0.0, 1.0)       # Cycles' TEX_IMAGE_MISSING_R, _G, _B
PINK_INSTEAD = "Cycles' missing-texture pink (1, 0, 1) instead"
WITHOUT_IT = "rendering without it"

_UDIM = re.compile(r"<UDIM>|<UVTILE>")


def abspath(path: str, id_data=None) -> str:
    """``path`` as written, made absolute as Blender makes it: ``//`` relative to the .blend or to
    the library ``id_data`` is linked from; normalised."""
    import bpy

    library = getattr(id_data, "library", None)
    return os.path.normpath(bpy.path.abspath(path, library=library))


def frame_path(filepath: str, frame: int) -> str:
    """The file of a sequence for ``frame``, as Blender makes it (``BLI_path_frame``): the digits
    just before the file's extension replaced by the frame, padded to their count."""
    directory, name = os.path.split(filepath)
    stem, dot, ext = name.rpartition(".")
    if not dot:
        stem, ext = name, ""
    digits = len(stem) - len(stem.rstrip("0123456789"))
    if digits == 0:
        return filepath
    sign = "-" if frame < 0 else ""
    name = f"{stem[:len(stem) - digits]}{sign}{abs(int(frame)):0{digits}d}{dot}{ext}"
    return os.path.join(directory, name)


def image_sequence_frame(image_user, frame: int) -> int:
    """The frame number of an image sequence's file read at scene ``frame`` through
    ``image_user`` (an Image Texture node's), Blender's ``BKE_image_user_frame_get``."""
    length = int(image_user.frame_duration)
    if length == 0:
        return 0
    f = frame - int(image_user.frame_start) + 1
    cyclic = bool(image_user.use_cyclic)
    if cyclic:
        f %= length
        if f == 0:
            f = length
    f = min(max(f, 0), length)
    if cyclic:
        f %= length
        if f == 0:
            f = length
    return f + int(image_user.frame_offset)


def tile_path(filepath: str, number: int) -> str:
    """A UDIM tile's file: the ``<UDIM>`` token replaced by the tile's number (``<UVTILE>`` by
    ``u<U>_v<V>``)."""
    u, v = (number - 1001) % 10 + 1, (number - 1001) // 10 + 1
    return _UDIM.sub(lambda m: str(number) if m.group(0) == "<UDIM>" else f"u{u}_v{v}", filepath)


def image_files(image, frame: int | None = None, image_user=None) -> list[str]:
    """The absolute paths of the files ``image`` reads (at scene ``frame``, through
    ``image_user``, for a sequence): none for a packed, generated or viewer image."""
    if image is None or image.packed_file is not None or image.source not in (
            'FILE', 'MOVIE', 'TILED', 'SEQUENCE'):
        return []
    if not image.filepath:
        return []
    path = abspath(image.filepath, image)
    if image.source == 'TILED':
        return [tile_path(path, t.number) for t in image.tiles]
    if image.source == 'SEQUENCE' and frame is not None and image_user is not None:
        return [frame_path(path, image_sequence_frame(image_user, frame))]
    return [path]


@dataclasses.dataclass(frozen=True)
class Missing:
    """What is missing of what an image reads: ``written`` the path as written, ``tried`` the
    absolute paths not found (the first named), ``total`` how many files it reads."""

    written: str
    tried: tuple[str, ...]
    total: int


def missing_image(image, frame: int | None = None, image_user=None) -> Missing | None:
    """What ``image`` reads that is not on disk, or None when it has everything (packed,
    generated, edited in memory and not saved, its files found)."""
    if image is None or getattr(image, "is_dirty", False):
        return None
    files = image_files(image, frame, image_user)
    gone = tuple(p for p in files if not os.path.isfile(p))
    if not gone:
        return None
    written = image.filepath
    if image.source == 'SEQUENCE' and frame is not None and image_user is not None:
        written = frame_path(written, image_sequence_frame(image_user, frame))   # the frame's file
    return Missing(written, gone, len(files))


def _subject(owner: str, what: str, name: str) -> str:
    return f"{owner} reads {what} '{name}'" if owner else f"{what[:1].upper()}{what[1:]} '{name}'"


def missing_message(owner: str, what: str, name: str, written: str, tried: tuple[str, ...] | list[str],
                    instead: str, total: int = 1) -> str:
    """The one line for a file a frame needs and does not find (module doc): ``owner`` what reads
    it (a material's node, a world's, a light), ``what`` and ``name`` the data-block, ``written``
    its path as written, ``tried`` the absolute paths not found, ``total`` the files it reads,
    ``instead`` what renders in its place."""
    first = tried[0]
    at = "" if os.path.normpath(written) == first else f" at '{first}'"
    if total > 1:
        where = f"{len(tried)} of its {total} files '{written}' not found, the first '{first}'"
    else:
        where = f"file '{written}' not found{at}"
    return f"{_subject(owner, what, name)}: {where}; {WITHOUT_IT}" + (f": {instead}" if instead else "")


def image_message(owner: str, image, missing: Missing) -> str:
    """The line for a missing image (shown in Cycles' missing-texture pink)."""
    return missing_message(owner, "image", image.name, missing.written, missing.tried, PINK_INSTEAD,
                           missing.total)


def unreadable_image_message(owner: str, image, tried: str) -> str:
    """The line for an image whose file ``tried`` is there but gives no pixels through Blender (a
    file Blender cannot decode; every image sequence: bpy gives no frame's pixels)."""
    why = ("is found, but the frames of an image sequence are not read by TFM"
           if image.source == 'SEQUENCE' else "gives no pixels")
    return f"{_subject(owner, 'image', image.name)}: file '{tried}' {why}; {WITHOUT_IT}: {PINK_INSTEAD}"


def image_problem(owner: str, image, frame: int | None = None, image_user=None) -> str | None:
    """The message when ``image`` cannot give its pixels this frame (a file missing, or read
    without pixels), else None: the one check every reader of image pixels makes."""
    missing = missing_image(image, frame, image_user)
    if missing is not None:
        return image_message(owner, image, missing)
    try:
        w, h = image.size
    except (AttributeError, RuntimeError):
        w = h = 0
    if w < 1 or h < 1 or image.channels < 1:
        tried = image_files(image, frame, image_user) or [image.filepath]
        return unreadable_image_message(owner, image, tried[0])
    return None


def scene_frame() -> int | None:
    """The current frame of the context scene (what an image sequence reads), or None."""
    try:
        import bpy

        return int(bpy.context.scene.frame_current)
    except (AttributeError, RuntimeError, ImportError):
        return None
