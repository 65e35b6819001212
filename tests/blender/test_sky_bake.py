"""A world whose Background colour is a Sky Texture is baked by Cycles in a separate process
(tfm_addon/blender/sky_bake.py); its match against Cycles is the conformance row `world_sky`."""

import threading

import bpy
import numpy as np
import pytest

from tfm_addon.blender import sky_bake, world
from tfm_addon.engine.environment import directions


@pytest.fixture
def sky(blank, monkeypatch):
    sky_bake._baked.clear()
    sky_bake._latest.clear()
    sky_bake._running.clear()
    w = bpy.data.worlds.new("Sky")
    bpy.context.scene.world = w
    bg = next(n for n in w.node_tree.nodes if n.bl_idname == 'ShaderNodeBackground')
    node = w.node_tree.nodes.new('ShaderNodeTexSky')
    w.node_tree.links.new(node.outputs["Color"], bg.inputs["Color"])
    return w, bg, node


def test_the_bake_places_each_direction_as_the_engine_reads_it(sky):
    """A world whose colour is its direction (Texture Coordinate Generated), baked by Cycles,
    equals the directions of the engine's equirectangular convention (up to a pixel's blur)."""
    w, bg, _ = sky
    coords = w.node_tree.nodes.new('ShaderNodeTexCoord')
    w.node_tree.links.new(coords.outputs["Generated"], bg.inputs["Color"])
    image, _ = sky_bake.bake(w)
    dirs, _ = directions(image.shape[:2])
    assert image.shape == (*sky_bake.BAKE_SIZE, 3)
    assert np.abs(image - dirs.reshape(image.shape)).max() < 0.03


class _Bakes:
    """Stands in for the Cycles process: counts the bakes, each held until ``release``."""

    def __init__(self):
        self.count = 0
        self.release = threading.Event()

    def __call__(self, tmp, cmd, exr, timeout):
        tmp.cleanup()
        self.count += 1
        self.release.wait(5.0)
        return np.full((*sky_bake.BAKE_SIZE, 3), 0.5, np.float32), ()


def test_a_bake_is_kept_by_the_world_and_the_viewport_does_not_wait(sky, monkeypatch):
    w, _, node = sky
    bakes = _Bakes()
    monkeypatch.setattr(sky_bake, "_run", bakes)
    env, note = world.environment(w, wait=False)
    assert env is None and "is being baked with Cycles" in note
    assert world.ambient_radiance(w, wait=False)[0] == tuple(w.color)
    _finish(bakes)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    bpy.context.scene.collection.objects.link(camera)
    for _ in range(3):                     # redraws and a camera move: no bake again
        camera.location.x += 1.0
        env, note = world.environment(w, wait=False)
        assert env is not None and "is baked with Cycles" in note
    assert bakes.count == 1
    bakes.release.clear()
    for _ in range(3):                     # a dragged slider: one bake at a time, the previous meanwhile
        node.sun_elevation += 0.1
        env, note = world.environment(w, wait=False)
        assert env is not None and "its previous bake lights the scene meanwhile" in note
        assert len(sky_bake._running) == 1
    _finish(bakes)
    assert bakes.count == 2
    world.environment(w, wait=False)       # the last value, baked next
    _finish(bakes)
    assert bakes.count == 3 and "is baked with Cycles" in world.environment(w, wait=True)[1]


def _finish(bakes):
    threads = list(sky_bake._running.values())
    bakes.release.set()
    for thread in threads:
        thread.join()


def test_a_failed_bake_falls_back_to_the_viewport_colour_with_a_line(sky, monkeypatch):
    w, _, _ = sky
    monkeypatch.setattr(sky_bake, "_command", lambda script, args: ["/nonexistent/blender"])
    ambient, note = world.ambient_radiance(w)
    assert ambient == tuple(w.color)
    assert "its Sky Texture could not be baked with Cycles (Blender could not be started" in note
