"""The speed benchmark's modes run and report what they time (the numbers themselves are
benchmarks: never asserted here)."""

from tfm_addon.bench import speed
from tfm_addon.engine import Renderer


def test_pixel_rows_time_each_size_and_frame_kind():
    renderer = Renderer()
    try:
        rows = speed.run_pixels(renderer, sizes=((32, 18), (64, 36)), repeats=1, grid=16)
    finally:
        renderer.release()
    assert [(r["frame"], r["size"]) for r in rows] == [("camera move", "32x18"), ("camera move", "64x36"),
                                                       ("light move", "32x18"), ("light move", "64x36")]
    assert all(v > 0 for r in rows for v in r["ms"].values())
    assert rows[0]["per pixel / first"] == 1.0 and rows[2]["per pixel / first"] == 1.0
    assert all(r["per pixel / first"] > 0 for r in rows)


def test_the_floor_is_the_frame_without_light_transmittance():
    scene = speed.bench_scenes(["smoke"])["smoke"]
    cases = speed.settings_for(scene)
    floor_scene, floor_settings = cases["floor (AUTO steps)"]
    assert floor_settings.method == speed.FLOOR and floor_settings.quality == "CUSTOM"
    assert cases["TFM-8 LINEAR"].coefficients == 8 and cases["brute force 100x100"].method == "BRUTE_FORCE"
