"""Render one chunk of a .blend's frames with the TFM Volumes extension: the worker of
render_frames.yaml (an Open Job Description task).

    python3 render_chunk.py --blend shot.blend --output /renders/shot/frame_#### --frames 11-20

Run by a Python interpreter that has Blender's bpy module; works too as
``blender -b --python render_chunk.py -- --blend ... --frames ...``. The add-on is taken from the
user preferences (the installed extension) or, failing that, from a ``tfm_addon`` package on
PYTHONPATH (a checkout of the repository). Exit status: 0 when every frame was written; 143 / 130
when SIGTERM / SIGINT stopped the render (the frame under way is not written; a signal before
the first frame or after the last writes nothing and exits with the same status); 1 when a frame
failed (no OpenGL, a frame over the memory budget, missing data in strict mode: the frame writes
nothing and the chunk stops); 2 when the add-on is not there or the .blend does not render with
TFM (Blender would render it with EEVEE).
"""

import argparse
import os
import signal
import sys


def _stop_before_the_render(signum, frame):
    # A cancel before the first frame (Python and Blender starting, the .blend loading) or after
    # the render job: nothing is being written; end with the status of the add-on's own stop.
    # While the frames render the add-on's handler replaces this one (and puts it back after).
    os.write(2, f"render_chunk: {signal.Signals(signum).name} outside the render: exiting with "
                f"status {128 + signum}\n".encode())
    os._exit(128 + signum)


# First of all, so that a farm's cancel (SIGTERM) or a Ctrl+C during the start does not end the
# process by the signal (a negative status, a traceback).
for _signum in (signal.SIGINT, signal.SIGTERM):
    signal.signal(_signum, _stop_before_the_render)

import bpy  # noqa: E402

ENGINE = "TFM"


def parse_frames(text: str) -> tuple[int, int]:
    """A contiguous chunk, "11-20" or "7" (as Open Job Description writes a CHUNK[INT] value of a
    CONTIGUOUS chunk): (first, last)."""
    first, sep, last = text.strip().partition("-")
    if sep and not first:                  # a negative first frame: "-5-3"
        first, sep, last = last.partition("-")
        first = "-" + first
    try:
        start = int(first)
        end = int(last) if sep else start
    except ValueError:
        raise SystemExit(f"render_chunk: --frames {text!r} is not a frame or a range first-last") from None
    if end < start:
        raise SystemExit(f"render_chunk: --frames {text!r}: the last frame is before the first")
    return start, end


def _enabled() -> bool:
    return hasattr(bpy.types, "TFM_OT_preflight")


def enable_addon() -> str:
    """Make the TFM render engine available before the .blend is opened (a file whose engine is
    not registered opens with EEVEE); where it came from."""
    if _enabled():                       # `blender -b --python`: the preferences are loaded
        return "enabled"
    # The bpy module starts with the factory settings: the installed, enabled extensions are
    # loaded only with the user preferences.
    bpy.ops.wm.read_userpref()
    if _enabled():
        return "the user preferences"
    try:
        import tfm_addon
    except ImportError:
        return ""
    tfm_addon.register()
    return f"tfm_addon ({os.path.dirname(os.path.abspath(tfm_addon.__file__))})" if _enabled() else ""


def main(argv: list[str]) -> int:
    if "--" in argv:
        argv = argv[argv.index("--") + 1:]
    parser = argparse.ArgumentParser(prog="render_chunk.py", description=__doc__.split("\n\n")[0])
    parser.add_argument("--blend", required=True, help="the .blend to render")
    parser.add_argument("--output", required=True,
                        help="the frames' path in Blender's form (#### is the frame number)")
    parser.add_argument("--frames", required=True, help="the chunk: first-last, or one frame")
    args = parser.parse_args(argv)
    first, last = parse_frames(args.frames)

    source = enable_addon()
    if not source:
        print("render_chunk: the TFM add-on is not enabled: install and enable the TFM Volumes "
              "extension for this interpreter's Blender (or put the add-on's checkout on PYTHONPATH)",
              file=sys.stderr, flush=True)
        return 2
    bpy.ops.wm.open_mainfile(filepath=os.path.abspath(args.blend))
    scene = bpy.context.scene
    if scene.render.engine != ENGINE:
        print(f"render_chunk: {args.blend} renders with {scene.render.engine}, not {ENGINE}",
              file=sys.stderr, flush=True)
        return 2
    scene.frame_start, scene.frame_end = first, last
    scene.render.filepath = os.path.abspath(args.output)
    print(f"render_chunk: frames {first}-{last} of {args.blend} into {scene.render.filepath} "
          f"(add-on from {source}, Blender {bpy.app.version_string})", flush=True)
    try:
        bpy.ops.render.render(animation=True)
    except RuntimeError as ex:          # a frame failed (its error was said): stop the chunk
        print(f"render_chunk: the render stopped: {ex}", file=sys.stderr, flush=True)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
