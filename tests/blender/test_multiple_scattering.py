"""Multiple scattering against Cycles with volume bounces (tfm_addon/bench/bounces.py): media the
octave constants were not fitted on, against stored Cycles references at 16 and 128 volume bounces
(tests/data/bounces, scripts/make_bounce_refs.py); and where the bounce count is read."""

import pytest

from tfm_addon.bench import bounces as bn
from tfm_addon.bench import conformance as cf
from tfm_addon.engine import metrics

SSIM_MIN = 0.95
BRIGHTNESS_TOL = 0.10
# Every held-out medium, the 40 m cloud among them, at 16 and 128 bounces (docs/multiple_scattering.md).
CASES = [(m, n) for m in bn.HELD_OUT for n in (16, 128)]


def _figures(medium, bounces, tmp_path):
    cycles, _ = bn.load_reference(medium, bounces)
    result = bn.render_tfm(medium, bounces, str(tmp_path))
    image = result.image[..., :3]
    return metrics.ssim(image, cycles), metrics.brightness_ratio(image, cycles)


@pytest.mark.parametrize("medium,bounces", CASES, ids=[f"{m}-{n}" for m, n in CASES])
def test_held_out_medium_matches_cycles_with_bounces(blank, tmp_path, medium, bounces):
    assert medium in bn.HELD_OUT
    ssim, ratio = _figures(medium, bounces, tmp_path)
    print(f"{medium} at {bounces} bounces: SSIM {ssim:.4f}, brightness {ratio:.3f}")
    assert ssim >= SSIM_MIN and abs(ratio - 1.0) <= BRIGHTNESS_TOL, (ssim, ratio)


def test_production_scale_cloud_needs_the_bounces(blank, tmp_path):
    """The 40 m white cloud (optical depths of tens to hundreds): single scattering has less than
    half of Cycles' brightness at 128 bounces (the bounces are what the test above checks)."""
    cycles, _ = bn.load_reference("cumulus", 128)
    single = bn.render_tfm("cumulus", 0, str(tmp_path)).image[..., :3]
    assert metrics.brightness_ratio(single, cycles) < 0.5


def test_a_medium_scatters_its_own_emission_with_no_bounces(blank, tmp_path):
    """A smoke lit by its glowing core alone: Cycles scatters the emission at 0 volume bounces
    (the scattered ray still gathers emission), and TFM does (engine/diffusion.py's emission
    field). With the object's Volume Scatter ray visibility off neither does: TFM then renders
    about half of Cycles' image with it on."""
    import bpy

    cycles, _ = bn.load_reference("glowing_smoke", 0)
    image = bn.render_tfm("glowing_smoke", 0, str(tmp_path)).image[..., :3]
    ssim, ratio = metrics.ssim(image, cycles), metrics.brightness_ratio(image, cycles)
    print(f"glowing_smoke at 0 bounces: SSIM {ssim:.4f}, brightness {ratio:.3f}")
    assert ssim >= 0.98 and abs(ratio - 1.0) <= 0.05, (ssim, ratio)

    bn.build("glowing_smoke", str(tmp_path / "off"), 0)
    for ob in bpy.context.scene.objects:
        if ob.type == 'VOLUME':
            ob.visible_volume_scatter = False
    scene = bpy.context.scene
    scene.render.engine = 'TFM'
    scene.render.film_transparent = True
    scene.tfm.samples = cf.TFM_SAMPLES
    bpy.ops.render.render()
    off = cf._read_render(str(tmp_path), "off")[..., :3]
    assert metrics.brightness_ratio(off, cycles) < 0.7


def test_volume_bounces_read_from_cycles_unless_set(blank, addon):
    extract = addon.blender.extract
    blank.cycles.volume_bounces = 7
    assert extract.render_settings(blank).volume_bounces == 7
    blank.tfm.volume_bounces = 0
    assert extract.render_settings(blank).volume_bounces == 0
    blank.tfm.volume_bounces = 32
    assert extract.render_settings(blank).volume_bounces == 32


def test_brightness_grows_smoothly_with_the_bounce_count(blank, tmp_path):
    """A held-out cloud at the counts an artist picks: the image never darkens as the count grows,
    and 15 and 16 bounces differ by under 2 % (the fitted rows' weights are interpolated in the
    count's logarithm; read from the row below instead, counts 4 to 15 would render one image and
    16 would be 9 % brighter on this cloud)."""
    counts = (1, 2, 3, 4, 6, 8, 12, 15, 16, 32, 64, 128)
    totals = [float(bn.render_tfm("dense_cloud_sun", n, str(tmp_path / str(n))).image[..., :3].sum())
              for n in counts]
    print(" ".join(f"{n}: {t / totals[0]:.3f}" for n, t in zip(counts, totals, strict=True)))
    assert all(b >= a * 0.999 for a, b in zip(totals, totals[1:], strict=False)), totals
    assert totals[counts.index(16)] / totals[counts.index(15)] < 1.02
    assert totals[counts.index(8)] / totals[counts.index(4)] > 1.02      # the count between rows counts
