"""Mesh visibility (Cycles' object settings): hidden from the camera, casting no shadow, holdout.

Each case is checked against renders of the same scene without the mesh or with it as usual, so
that the numbers can only agree if the flag changes exactly the passes it should. The smoke
scene's bar (above the frame) casts the shaft; its ground is what the camera sees.
"""

import dataclasses

import numpy as np
import pytest

from tfm_addon.engine import RenderSettings
from tfm_addon.scenes import smoke_scene

SETTINGS = RenderSettings(view_steps=48, light_steps=48, map_resolution=128)


def _with(scene, name, **flags):
    meshes = tuple(dataclasses.replace(m, **flags) if m.name == name else m for m in scene.meshes)
    return dataclasses.replace(scene, meshes=meshes)


def _without(scene, name):
    return dataclasses.replace(scene, meshes=tuple(m for m in scene.meshes if m.name != name))


@pytest.fixture(scope="module")
def renders(renderer):
    scene = smoke_scene(width=80, height=48, n=32)
    assert {m.name for m in scene.meshes} == {"Bar", "Ground"}
    cases = {"full": scene, "no_bar": _without(scene, "Bar"), "no_ground": _without(scene, "Ground"),
             "bar_no_shadow": _with(scene, "Bar", cast_shadow=False),
             "bar_neither": _with(scene, "Bar", cast_shadow=False, visible_camera=False),
             "ground_unseen": _with(scene, "Ground", visible_camera=False),
             "ground_holdout": _with(scene, "Ground", holdout=True)}
    # Shadow linking (the light's blockers): every solid but the bar; no medium for the surfaces.
    light = scene.lights[0]
    cases["bar_unlinked"] = dataclasses.replace(scene, lights=(dataclasses.replace(
        light, shadow_solids=("Ground",)),) + scene.lights[1:])
    cases["media_unlinked"] = dataclasses.replace(scene, lights=(dataclasses.replace(
        light, media_shadow_surfaces=False),) + scene.lights[1:])
    cases["no_media"] = dataclasses.replace(scene, media=())
    out = {name: renderer.render(s, SETTINGS) for name, s in cases.items()}
    # Where the camera sees the ground.
    out["ground_px"] = out["full"].combined[:, :, 3] == 1.0
    return out


def test_the_scene_has_a_shaft_and_a_ground(renders):
    assert 0.2 < renders["ground_px"].mean() < 0.9
    full, no_bar = renders["full"].passes["scattering"], renders["no_bar"].passes["scattering"]
    assert np.abs(full - no_bar).max() > 0.05 * full.max()


def test_no_shadow_removes_the_bar_shaft(renders):
    assert np.abs(renders["bar_no_shadow"].combined - renders["no_bar"].combined).max() <= 1e-6
    assert np.array_equal(renders["bar_neither"].combined, renders["no_bar"].combined)


def test_shadow_linking_leaves_out_the_bar_or_the_media(renders):
    """A light whose blockers leave out the bar renders as a bar that casts no shadow; one whose
    blockers leave out the media lights the surfaces as if there were none, while the media keep
    their own shadows (the scattering is unchanged)."""
    assert np.abs(renders["bar_unlinked"].combined - renders["bar_no_shadow"].combined).max() <= 1e-6
    unlinked, full, bare = renders["media_unlinked"], renders["full"], renders["no_media"]
    np.testing.assert_allclose(unlinked.passes["scattering"], full.passes["scattering"], atol=1e-6)
    ground = renders["ground_px"]
    lit = bare.passes["surfaces"][ground]
    np.testing.assert_allclose(unlinked.passes["surfaces"][ground], lit, atol=1e-5 * lit.max())
    assert (lit - full.passes["surfaces"][ground]).max() > 0.2 * lit.max()   # the smoke's shadow


def test_hidden_from_camera_is_seen_through(renders):
    unseen, none = renders["ground_unseen"], renders["no_ground"]
    assert np.abs(unseen.combined - none.combined).max() <= 1e-6
    assert unseen.combined[:, :, 3][renders["ground_px"]].max() < 1.0


def test_holdout_cuts_alpha_and_radiance(renders):
    holdout, full = renders["ground_holdout"], renders["full"]
    ground, sky = renders["ground_px"], ~renders["ground_px"]
    assert np.abs(holdout.combined - full.combined)[sky].max() <= 1e-6
    assert np.abs(holdout.passes["surfaces"][ground]).max() == 0.0
    assert full.passes["surfaces"][ground].max() > 0.0
    t = holdout.passes["transmittance"][ground].mean(axis=-1)
    assert t.min() < 0.99                       # some of the ground lies behind the smoke
    np.testing.assert_allclose(holdout.combined[:, :, 3][ground], 1.0 - t, atol=1e-6)
    np.testing.assert_allclose(holdout.combined[:, :, :3], holdout.passes["scattering"], atol=1e-6)
    # The medium in front of the ground is the same as with a seen ground.
    np.testing.assert_allclose(holdout.passes["scattering"], full.passes["scattering"], atol=1e-6)


def test_visibility_matches_the_reference(renderer):
    """The numpy reference, which shares no code with the GPU passes, with a bar that casts no
    shadow and a holdout ground."""
    from references import render_reference

    from tfm_addon.engine.metrics import ssim

    scene = _with(_with(smoke_scene(width=64, height=40, n=32), "Bar", cast_shadow=False),
                  "Ground", holdout=True)
    steps = dict(view_steps=64, light_steps=64)
    ref = render_reference(scene, **steps)
    out = renderer.render(scene, RenderSettings(map_resolution=256, **steps))
    alpha = lambda image: np.repeat(image.combined[..., 3:4], 3, axis=-1)  # noqa: E731
    assert ssim(out.rgb, ref.rgb) >= 0.99
    assert ssim(alpha(out), alpha(ref)) >= 0.99
    assert (ref.combined[..., 3] < 1.0).all()      # no pixel is a seen solid


def test_camera_visibility_rebuilds_no_light_map():
    from tfm_addon.engine import Renderer

    renderer = Renderer()
    try:
        scene = smoke_scene(width=32, height=24, n=16)
        renderer.render(scene, SETTINGS)

        def rebuilt(s):
            renderer.render(scene, SETTINGS)      # from the usual scene's maps each time
            before = dict(renderer.counters)
            renderer.render(s, SETTINGS)
            return {k: renderer.counters[k] - before.get(k, 0)
                    for k in ("shadow_maps", "tfms", "gbuffers")}

        assert rebuilt(_with(scene, "Ground", visible_camera=False)) == dict(shadow_maps=0, tfms=0,
                                                                             gbuffers=1)
        assert rebuilt(_with(scene, "Ground", holdout=True)) == dict(shadow_maps=0, tfms=0, gbuffers=1)
        assert rebuilt(_with(scene, "Bar", cast_shadow=False)) == dict(shadow_maps=1, tfms=1, gbuffers=0)
    finally:
        renderer.release()
