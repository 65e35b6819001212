"""The lights benchmark's rows at its quick size: the maps each frame builds (counts, not times)."""

from tfm_addon.bench import lights_bench


def test_lights_bench_rows_count_the_maps_per_face():
    rows = lights_bench.run(lights_bench.QUICK, log=lambda *a: None)
    maps = {(r["case"], r["kind"], r["count"]): r["maps"] for r in rows}
    for n in lights_bench.LIGHT_COUNTS:
        assert maps[("lights", "SPOT", n)] == 2 * n       # a shadow map and a TFM per spot
        assert maps[("lights", "SUN", n)] == 2 * n        # one orthographic face per sun
        assert 2 * n <= maps[("lights", "POINT", n)] <= 12 * n   # up to six faces per point light
    assert all(maps[("volumes", "SPOT", n)] == 2 for n in lights_bench.VOLUME_COUNTS)
    assert all(r["seconds"] > 0 for r in rows)
    assert "| lights | point | 8 |" in lights_bench.report(rows)
