"""The viewport benchmark: per edit, the time to the first image, to full resolution and
to 16 samples, the maps each edit rebuilt, and the longest time an add-on callback held
Blender's thread; and final-render antialiasing against Cycles.

``run`` drives the progressive view (engine.progressive) on a RenderWorker the way the viewport
does, with the timestamps of the frames it publishes; the callbacks are timed in a Blender
process of their own (``python -m tfm_addon.bench.viewport_bench callbacks W H N OUT.json``):
``view_update``'s body per edit (depsgraph read), and ``view_draw``'s (the view's camera, the
request, the texture upload and the draw into a half-float offscreen).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

from ..engine import RenderSettings, Scene
from ..engine.progressive import ProgressiveView
from ..engine.worker import RenderWorker
from ..scenes import demo_scene, smoke_density, smoke_scene
from .common import markdown_table

EDITS = ("camera orbit", "light move", "sigma change", "density scale", "frame change (.vdb)",
         "nothing changed")
SAMPLES = 16


class _TimedView(ProgressiveView):
    """Records when each frame of the current request was published."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.events: list[tuple[float, str, int]] = []
        self.converged = threading.Event()

    def _publish(self, generation, t0, image, stage, samples, target, warnings):
        shown = super()._publish(generation, t0, image, stage, samples, target, warnings)
        if shown:
            self.events.append((time.perf_counter(), stage, samples))
            if samples >= target and stage != "coarse":
                self.converged.set()
        return shown


def _orbit(scene: Scene, degrees: float) -> Scene:
    m = np.array(scene.camera.matrix_world)
    a = math.radians(degrees)
    rot = np.eye(4)
    rot[:2, :2] = [[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]]
    return dataclasses.replace(scene, camera=dataclasses.replace(scene.camera, matrix_world=rot @ m))


def edited(scene: Scene, edit: str, step: int) -> Scene:
    """``scene`` after one edit of kind ``edit`` (``step`` makes successive edits differ)."""
    medium, light = scene.media[0], scene.lights[0]
    if edit == "camera orbit":
        return _orbit(scene, 5.0 * (step + 1))
    if edit == "light move":
        m = np.array(light.matrix_world)
        m[0, 3] += 0.2 * (step + 1)
        return dataclasses.replace(scene, lights=(dataclasses.replace(light, matrix_world=m),))
    if edit == "sigma change":
        k = 1.0 + 0.2 * (step + 1)
        return dataclasses.replace(scene, media=(dataclasses.replace(
            medium, sigma_s=tuple(k * s for s in medium.sigma_s)),))
    if edit == "density scale":  # the Principled Volume's Density input: both sigmas scale
        k = 1.0 + 0.25 * (step + 1)
        return dataclasses.replace(scene, media=(dataclasses.replace(
            medium, sigma_s=tuple(k * s for s in medium.sigma_s),
            sigma_a=tuple(k * s for s in medium.sigma_a)),))
    if edit == "frame change (.vdb)":  # the next file of a sequence: another grid, same size
        n = medium.density.shape
        d = (smoke_density(n[0], seed=10 + step) if n[0] == n[1] == n[2]
             else np.roll(medium.density, step + 1, 0))
        return dataclasses.replace(scene, media=(dataclasses.replace(medium, density=d),))
    return scene


def _stall_while(busy, limit_s: float) -> float:
    """While ``busy()`` (at most ``limit_s``), wake every millisecond as a Python UI thread would;
    the longest gap between wake-ups, seconds: how long the worker kept this thread from running
    (the worker's GL calls hold Python's GIL unless they release it), plus the OS's scheduling."""
    longest, end = 0.0, time.perf_counter() + limit_s
    last = time.perf_counter()
    while busy() and last < end:
        time.sleep(0.001)
        now = time.perf_counter()
        longest, last = max(longest, now - last), now
    return longest


def _counts(worker: RenderWorker) -> dict:
    return dict(worker.counters)


def measure(name: str, scene: Scene, settings: RenderSettings, samples: int = SAMPLES,
            repeats: int = 1, log=print) -> list[dict]:
    """Rows per edit: ms to the first image, to full resolution and to ``samples`` samples, and
    the maps rebuilt (median over ``repeats`` edits of each kind)."""
    worker = RenderWorker()
    view = _TimedView(worker)
    rows = []
    try:
        key = 0
        current = scene

        def settle(target_scene, same_key=False):
            nonlocal key
            view.events.clear()
            view.converged.clear()
            before = _counts(worker)
            t0 = time.perf_counter()
            if not same_key:
                key += 1
            posted = view.request(key, target_scene, settings, samples)
            stall = _stall_while(lambda: posted and not view.converged.is_set(), 600)
            after = _counts(worker)
            delta = {k: after.get(k, 0) - before.get(k, 0) for k in ("grid_uploads", "shadow_maps", "tfms")}
            if not posted:
                return dict(first=0.0, full=0.0, converged=0.0, posted=False, stall=0.0, **delta)
            times = {"first": view.events[0][0] - t0}
            times["full"] = next(t for t, stage, _ in view.events if stage != "coarse") - t0
            times["converged"] = view.events[-1][0] - t0
            return dict(posted=True, coarse=view.events[0][1] == "coarse", stall=stall, **times, **delta)

        idle = _stall_while(lambda: True, 1.0)
        first = settle(current)
        rows.append(dict(scene=name, edit="first image (compiles shaders)", **_ms(first),
                         stall_ms=1000.0 * first["stall"], idle_stall_ms=1000.0 * idle))
        settle(_orbit(current, 0.5))       # warm: every program compiled at both sizes
        for edit in EDITS:
            runs = []
            for step in range(repeats):
                nxt = edited(current, edit, step)
                runs.append(settle(nxt, same_key=edit == "nothing changed"))
                current = nxt
            mid = {k: float(np.median([r[k] for r in runs])) for k in ("first", "full", "converged")}
            rows.append(dict(scene=name, edit=edit, **_ms(mid), **{k: runs[-1][k] for k in (
                "grid_uploads", "shadow_maps", "tfms")}, posted=runs[-1]["posted"],
                stall_ms=1000.0 * max(r["stall"] for r in runs)))
            log(f"viewport {name}: {edit}: first {rows[-1]['first_ms']:.0f} ms, "
                f"full {rows[-1]['full_ms']:.0f} ms, {samples} samples {rows[-1]['converged_ms']:.0f} ms")
    finally:
        worker.close()
    return rows


def _ms(times: dict) -> dict:
    return {f"{k}_ms": 1000.0 * float(times[k]) for k in ("first", "full", "converged")} | {
        k: times[k] for k in ("grid_uploads", "shadow_maps", "tfms") if k in times}


def callbacks(width: int, height: int, n: int, out: str) -> None:
    """In a Blender process: time the add-on's viewport callbacks per edit on the demo scene."""
    import bpy
    import gpu
    from mathutils import Matrix

    import tfm_addon
    from tfm_addon.blender import camera as bl_camera
    from tfm_addon.blender import scene_builder, viewport
    from tfm_addon.scenes import demo_scene

    tfm_addon.register()
    folder = Path(out).parent
    scene = bpy.context.scene
    scene.camera = bpy.data.objects.new("Init", bpy.data.cameras.new("Init"))
    scene.collection.objects.link(scene.camera)
    scene.render.engine = 'BLENDER_WORKBENCH'
    scene.render.resolution_x = scene.render.resolution_y = 32
    bpy.ops.render.render()                       # brings the GPU module up (background mode)
    bpy.ops.wm.read_homefile(use_empty=True)
    demo = demo_scene(width=width, height=height, n=n)
    made = scene_builder.build(demo, str(folder), settings=RenderSettings(quality="AUTO"))
    scene = bpy.context.scene
    # The medium as a two-frame .vdb sequence, for the frame change.
    m = np.asarray(demo.media[0].index_to_world, dtype=np.float64)
    voxel = float(abs(np.linalg.det(m[:3, :3])) ** (1.0 / 3.0))
    for frame, shift in ((1, 0), (2, 3)):
        scene_builder.write_vdb(str(folder / f"seq_{frame:04d}.vdb"),
                                np.roll(demo.media[0].density, shift, axis=0), voxel_size_m=voxel)
    volume = made["medium"].data
    volume.filepath = str(folder / "seq_0001.vdb")
    volume.is_sequence = True
    volume.frame_start, volume.frame_duration, volume.sequence_mode = 1, 2, 'CLIP'
    scene.frame_set(1)
    offscreen = gpu.types.GPUOffScreen(width, height, format='RGBA16F')
    session = viewport.ViewportSession()
    timings = []

    class Engine:  # what DrawTexture.draw asks of a RenderEngine
        def bind_display_space_shader(self, scene):
            pass

        def unbind_display_space_shader(self):
            pass

    from tfm_addon.blender.changes import Change, changes_from_depsgraph

    seen = []

    def handler(scene, depsgraph):  # what view_update's depsgraph holds: this update's changes
        seen.append(changes_from_depsgraph(depsgraph))

    bpy.app.handlers.depsgraph_update_post.append(handler)
    bpy.app.handlers.frame_change_post.append(handler)   # a frame change's updates come here

    def view_update(label):
        bpy.context.view_layer.update()
        flags = Change.NONE
        for f in seen:
            flags |= f
        dg = bpy.context.evaluated_depsgraph_get()
        t0 = time.perf_counter()
        session.update(dg, None if label == "first" else flags)
        return time.perf_counter() - t0

    texture = [None, None]

    def view_draw(camera_matrix):
        t0 = time.perf_counter()
        dg = bpy.context.evaluated_depsgraph_get()
        ob = scene.camera.evaluated_get(dg)
        view = np.linalg.inv(bl_camera.without_scale(camera_matrix))
        projection = np.array(ob.calc_matrix_camera(dg, x=width, y=height))
        camera = bl_camera.camera_from_view(view, projection, width, height)
        session.request(camera, SAMPLES)
        t_request = time.perf_counter() - t0
        frame = session.frame()
        t1 = time.perf_counter()
        if frame is not None:
            if texture[1] is not frame:
                texture[0], texture[1] = viewport.DrawTexture(frame.image, frame.pixels), frame
            with offscreen.bind(), gpu.matrix.push_pop(), gpu.matrix.push_pop_projection():
                gpu.matrix.load_identity()
                gpu.matrix.load_projection_matrix(Matrix(
                    ((2 / width, 0, 0, -1), (0, 2 / height, 0, -1), (0, 0, 1, 0), (0, 0, 0, 1))))
                texture[0].draw(Engine(), scene, width, height)
            gpu.state.active_framebuffer_get()
        return t_request, time.perf_counter() - t1, time.perf_counter() - t0

    def settle():
        for _ in range(3000):
            if session.view.state == "idle":
                return
            time.sleep(0.01)

    cam = scene.camera
    first_read = view_update("first")
    view_draw(cam.matrix_world)
    settle()
    view_draw(cam.matrix_world)  # the converged frame's texture
    medium = made["medium"]
    light = made["lights"][0]
    node = medium.data.materials[0].node_tree.nodes["Principled Volume"]

    edits = {
        "camera orbit": lambda: None,
        "light move": lambda: setattr(light, "location", light.location + type(light.location)((0.2, 0, 0))),
        "sigma change": lambda: setattr(node.inputs["Color"], "default_value", (0.8, 0.7, 0.6, 1.0)),
        "density scale": lambda: setattr(node.inputs["Density"], "default_value",
                                         node.inputs["Density"].default_value * 1.25),
        "frame change (.vdb)": lambda: scene.frame_set(2),
        "nothing changed": lambda: None,
    }
    matrix = Matrix(cam.matrix_world)
    for label, edit in edits.items():
        seen.clear()
        edit()
        if label == "camera orbit":
            matrix = Matrix.Rotation(math.radians(5.0), 4, 'Z') @ matrix
        update = 0.0 if label == "camera orbit" else view_update(label)
        request, draw_old, total = view_draw(matrix)
        settle()
        request2, draw_new, total2 = view_draw(matrix)   # the redraw that shows the new frame
        changes = "(view only)" if label == "camera orbit" else str(session.last_changes)
        timings.append(dict(edit=label, changes=changes, view_update_ms=1000 * update,
                            view_draw_request_ms=1000 * request,
                            view_draw_ms=1000 * max(total, total2), upload_draw_ms=1000 * draw_new))
    offscreen.free()
    bpy.app.handlers.depsgraph_update_post.remove(handler)
    bpy.app.handlers.frame_change_post.remove(handler)
    viewport.stop_polling()
    from tfm_addon.blender.volumes import grid_cache

    medium = session.extraction.media[0]
    Path(out).write_text(json.dumps(dict(
        first_read_ms=1000 * first_read, edits=timings, grid_reads=grid_cache.reads,
        medium_shape=None if medium is None else list(medium.density.shape),
        warnings=session.warnings), indent=1))
    tfm_addon.unregister()


def run_callbacks(width: int, height: int, n: int, folder: Path, log=print) -> dict | None:
    folder.mkdir(parents=True, exist_ok=True)
    out = folder / "callbacks.json"
    env = dict(os.environ)
    root = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
    done = subprocess.run([sys.executable, "-m", "tfm_addon.bench.viewport_bench", "callbacks",
                           str(width), str(height), str(n), str(out)],
                          env=env, capture_output=True, text=True, timeout=900)
    if done.returncode != 0 or not out.exists():
        log(f"viewport callbacks failed: {done.stderr[-1500:]}")
        return None
    return json.loads(out.read_text())


AA_SAMPLES = (1, 2, 4, 8, 10, 12, 14, 16, 18, 24, 32, 48, 64)
AA_UNIFORM_SAMPLES = (12, 16, 24, 32)   # the same with adaptive sampling off: every pixel takes every sample
AA_ROUNDS = 5
AA_REPEATS = 3                      # TFM timings per row and round (median), the rows interleaved


def run_aa(out: Path, width: int = 160, height: int = 90, n: int = 64, log=print,
           rounds: int = AA_ROUNDS) -> str:
    """Final-render antialiasing: TFM at AA_SAMPLES samples (quality AUTO, adaptive sampling) and
    at AA_UNIFORM_SAMPLES without adaptive sampling, Cycles at 256 spp with the reference
    settings of BLENDER.md (its adaptive sampling off) and with its adaptive sampling on (Blender's
    defaults), all against Cycles at 4096 spp (adaptive off, rendered once), on the smoke with the
    bar and the ground plane. One run of ``rounds`` rounds, each timing every TFM row AA_REPEATS
    times (interleaved; median) and then the two Cycles 256 spp renders (their own Blender
    process, timed around the render call), so that the load of the shared machine weighs on both
    alike; medians over the rounds. TFM 'cold' is a frame from scratch: AUTO's scene statistics,
    the grid upload, the maps and every sample; 'warm' reuses them (a re-render)."""
    import pickle
    import statistics

    from ..engine import Renderer, quality
    from ..engine.exr import read_exr
    from ..engine.sampling import (
        ADAPTIVE_FRAME_SAMPLES,
        MANY_SAMPLES,
        Accumulator,
        frame_settings,
        iter_samples,
    )
    from .common import compare
    from .timing import time_side_by_side

    folder = out / "viewport" / "aa"
    folder.mkdir(parents=True, exist_ok=True)
    scene = smoke_scene(width=width, height=height, n=n)
    with open(folder / "scene.pkl", "wb") as f:
        pickle.dump(scene, f)
    env = dict(os.environ)
    root = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")

    def cycles(name: str, samples: list[int], gt: int = 0, adaptive: list[int] = ()) -> dict | str:
        sub = folder / name
        sub.mkdir(parents=True, exist_ok=True)
        job = dict(scene=str(folder / "scene.pkl"), folder=str(sub), cycles_samples=samples,
                   cycles_gt_samples=gt, cycles_adaptive_samples=list(adaptive), eevee_runs=[])
        (sub / "job.json").write_text(json.dumps(job))
        done = subprocess.run([sys.executable, "-m", "tfm_addon.bench.blender_side", str(sub / "job.json")],
                              env=env, capture_output=True, text=True, timeout=3600, cwd=root)
        if done.returncode != 0:
            return f"AA benchmark: Cycles failed: {done.stdout[-1000:]} {done.stderr[-1000:]}"
        renders = json.loads((sub / "results.json").read_text())["renders"]
        for render in renders:
            ch = read_exr(sub / render["file"])
            render["image"] = np.stack([ch[c] for c in "RGB"], axis=-1)
        return renders

    renderer = Renderer()
    settings = RenderSettings(quality="AUTO")
    rows_of = ([(k, 0.01, str(k)) for k in AA_SAMPLES]
               + [(k, None, f"{k}, every pixel") for k in AA_UNIFORM_SAMPLES])
    shaded = {}

    def render(k, threshold):
        acc = Accumulator()
        for _ in iter_samples(renderer, scene, settings, k, passes=False, accumulator=acc,
                              adaptive_threshold=threshold):
            pass
        return acc

    images = {}
    for k, threshold, label in rows_of:
        before = renderer.counters["pixels_shaded"]
        images[label] = render(k, threshold).output.combined[..., :3]
        shaded[label] = (renderer.counters["pixels_shaded"] - before) / (k * width * height)

    def cold(k, threshold):
        def go():
            renderer.clear_maps()
            quality._cache.clear()       # AUTO's scene statistics too: a new frame from scratch
            render(k, threshold)
        return go

    def warm(k, threshold):
        return lambda: render(k, threshold)

    contenders = ({("cold", label): cold(k, th) for k, th, label in rows_of}
                  | {("warm", label): warm(k, th) for k, th, label in rows_of})
    per_round, c256, c256a, load = [], [], [], []
    for r in range(rounds):
        per_round.append(time_side_by_side(contenders, AA_REPEATS))
        load.append(os.getloadavg()[0])
        log(f"viewport AA: round {r + 1}/{rounds}: TFM timed; Cycles 256 spp running")
        c = cycles(f"cycles256_{r}", [256], adaptive=[256])
        if isinstance(c, str):
            return c
        c256.append(c[0])
        c256a.append(c[1])
        log(f"viewport AA: round {r + 1}/{rounds}: Cycles 256 spp {c[0]['seconds']:.2f} s, "
            f"adaptive {c[1]['seconds']:.2f} s")
    renderer.release()
    times = {key: statistics.median(t[key] for t in per_round) for key in contenders}
    log("viewport AA: Cycles 4096 spp (the reference) running")
    gt = cycles("cycles4096", [], 4096)
    if isinstance(gt, str):
        return gt
    gt = gt[0]
    reference = gt["image"]
    m256 = compare(c256[0]["image"], reference)     # every round renders seed 1: the same image
    m256a = compare(c256a[0]["image"], reference)
    c256_s = statistics.median(c["seconds"] for c in c256)
    c256a_s = statistics.median(c["seconds"] for c in c256a)
    rows = []
    metrics = {label: compare(images[label], reference) for _, _, label in rows_of}
    for _, _, label in rows_of:
        m = metrics[label]
        rows.append([label, f"{m['ssim']:.5f}", f"{m['psnr']:.2f}", f"{m['brightness']:.4f}",
                     f"{100 * shaded[label]:.0f}", f"{1000 * times[('cold', label)]:.1f}",
                     f"{1000 * times[('warm', label)]:.1f}"])
    for name, m, sec in (("Cycles 256 spp", m256, c256_s), ("Cycles 256 spp, adaptive", m256a, c256a_s)):
        rows.append([name, f"{m['ssim']:.5f}", f"{m['psnr']:.2f}", f"{m['brightness']:.4f}", "",
                     f"{1000 * sec:.0f}", ""])
    chosen = frame_settings(scene, settings, AA_SAMPLES[-1])
    lines = [f"## Final-render antialiasing: smoke {n}^3 with bar and ground, {width}x{height}",
             "", "TFM at each sample count (quality AUTO: here a "
             f"{chosen.coefficients}-coefficient TFM from {MANY_SAMPLES} samples on, "
             f"{chosen.view_steps} view steps a sample at {AA_SAMPLES[-1]}; adaptive sampling from "
             f"{ADAPTIVE_FRAME_SAMPLES} samples on, then the same with every pixel taking every sample) "
             "and Cycles at 256 spp (adaptive sampling off as in the reference, then on with Blender's "
             f"defaults), against Cycles at {gt['samples']} spp ({gt['seconds']:.1f} s, rendered once, "
             "adaptive sampling off). 'pixels %': the pixels the light passes shaded, per sample. TFM "
             "ms per frame from scratch ('cold': AUTO's scene statistics, grid, maps, every sample) "
             f"and re-rendered ('warm'). {rounds} rounds, each timing every TFM row {AA_REPEATS} times "
             "(interleaved, median) and then the Cycles 256 spp renders (their own process, timed "
             "around the render call, seed 1); medians over the rounds.", ""]
    lines.append(markdown_table(["samples", "SSIM", "PSNR dB", "brightness", "pixels %", "TFM ms (cold)",
                                 "TFM ms (warm)"], rows))
    lines += ["", "Per round, Cycles 256 spp s: " + ", ".join(f"{c['seconds']:.2f}" for c in c256)
              + "; adaptive: " + ", ".join(f"{c['seconds']:.2f}" for c in c256a)
              + "; load average (1 min) after the TFM rows: " + ", ".join(f"{x:.1f}" for x in load)]
    adaptive_rows = [str(k) for k in AA_SAMPLES]
    for name, m, cyc, sec in (("Cycles-256", m256, c256, c256_s),
                              ("Cycles-256 with its adaptive sampling", m256a, c256a, c256a_s)):
        reach = [label for label in adaptive_rows if metrics[label]["ssim"] >= m["ssim"]]
        if reach:
            label = reach[0]
            ratio = times[("cold", label)] / sec
            rr = [t[("cold", label)] / c["seconds"] for t, c in zip(per_round, cyc, strict=True)]
            lines += ["", f"TFM reaches {name}'s SSIM ({m['ssim']:.5f}) at {label} samples "
                      f"({metrics[label]['ssim']:.5f}) in {1000 * times[('cold', label)]:.1f} ms from "
                      f"scratch, {ratio:.4f}x Cycles' {sec:.2f} s (1/{1 / ratio:.0f}; target 1/50); per "
                      "round 1/" + ", 1/".join(f"{1 / x:.0f}" for x in rr) + "."]
        else:
            best = max(metrics[g]["ssim"] for g in adaptive_rows)
            lines += ["", f"TFM does not reach {name}'s SSIM ({m['ssim']:.5f}) within "
                      f"{adaptive_rows[-1]} samples (best {best:.5f})."]
    text = "\n".join(lines)
    (folder / "aa.md").write_text(text + "\n")
    return text


def run(quick: bool, out: Path, log=print, blender: bool = True, aa: bool = True) -> str:
    """The viewport section: writes <out>/viewport.md and returns its text."""
    size = (240, 135) if quick else (960, 540)
    n_smoke = 32 if quick else 128
    settings = RenderSettings(quality="AUTO")
    scenes = [("demo", demo_scene(width=size[0], height=size[1], n=32 if quick else 64)),
              (f"smoke {n_smoke}^3", smoke_scene(width=size[0], height=size[1], n=n_smoke))]
    rows = []
    for name, scene in scenes:
        rows += measure(name, scene, settings, samples=SAMPLES, repeats=1 if quick else 3, log=log)
    cb = run_callbacks(size[0], size[1], 32 if quick else 64, out / "viewport", log) if blender else None
    text = report(rows, cb, size)
    (out / "viewport.json").write_text(json.dumps(dict(size=list(size), rows=rows, callbacks=cb), indent=1))
    if blender and aa and not quick:
        text += "\n\n" + run_aa(out, log=log)
    (out / "viewport.md").write_text(text + "\n")
    return text


def report(rows: list[dict], cb: dict | None, size) -> str:
    lines = [f"## Viewport: {size[0]}x{size[1]}, quality AUTO, {SAMPLES} samples", "",
             "Times from the request (what view_draw posts) to the first published frame (coarse, a "
             "quarter of the side, or full when the last full frame took < 50 ms), to the full-"
             "resolution frame, and to the converged mean of 16 samples; maps rebuilt by the edit.", ""]
    header = ["scene", "edit", "first image ms", "full res ms", f"{SAMPLES} samples ms",
              "grid uploads", "shadow maps", "TFMs", "UI thread stall ms"]
    body = [[r["scene"], r["edit"] + ("" if r.get("posted", True) else " (no request)"),
             f"{r['first_ms']:.0f}", f"{r['full_ms']:.0f}", f"{r['converged_ms']:.0f}",
             str(r.get("grid_uploads", "")), str(r.get("shadow_maps", "")), str(r.get("tfms", "")),
             f"{r.get('stall_ms', 0.0):.0f}"]
            for r in rows]
    lines.append(markdown_table(header, body))
    idle = [r["idle_stall_ms"] for r in rows if "idle_stall_ms" in r]
    if idle:
        lines += ["", "UI thread stall: the longest gap between the 1 ms wake-ups of a Python thread "
                  "while the worker refined the image (the worker's GL waits release Python's GIL); "
                  f"the same thread with the worker idle: {max(idle):.0f} ms (the machine's own "
                  "scheduling noise)."]
    if cb:
        lines += ["", "Add-on callbacks on Blender's thread (demo scene, ms): view_update's body "
                  "(depsgraph read of what changed), view_draw's (request, plus texture upload and "
                  f"draw when a new frame is shown). First read of the scene: {cb['first_read_ms']:.0f} ms "
                  "(includes the first volume read).", ""]
        lines.append(markdown_table(
            ["edit", "view_update ms", "view_draw request ms", "view_draw ms (longest)", "upload+draw ms"],
            [[e["edit"], f"{e['view_update_ms']:.1f}", f"{e['view_draw_request_ms']:.1f}",
              f"{e['view_draw_ms']:.1f}", f"{e['upload_draw_ms']:.1f}"] for e in cb["edits"]]))
        longest = max(max(e["view_update_ms"], e["view_draw_ms"]) for e in cb["edits"])
        lines += ["", f"Longest callback: {longest:.1f} ms (target 20 ms)."]
    return "\n".join(lines)


if __name__ == "__main__":
    if len(sys.argv) >= 2 and sys.argv[1] == "callbacks":
        callbacks(int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[5])
    elif len(sys.argv) >= 2 and sys.argv[1] == "aa":       # the antialiasing part alone
        print(run_aa(Path(sys.argv[2] if len(sys.argv) > 2 else "out/bench")))
    else:
        print(run("--quick" in sys.argv, Path("out/bench"), blender="--no-blender" not in sys.argv))
