"""The emission benchmark row runs and times what it says: the same maps for every case."""

from tfm_addon.bench import emission_bench


def test_emission_row_rebuilds_nothing_while_timing():
    rows = emission_bench.run(emission_bench.QUICK, log=lambda *_: None)
    assert [r["case"] for r in rows] == ["no emission", "emission + blackbody",
                                         "emission + blackbody + colour grid", "constant emission"]
    assert all(r["seconds"] > 0 and r["rebuilt"] == 0 for r in rows)
    assert rows[0]["ratio"] == 1.0
    assert "Target: emission adds at most 10 %" in emission_bench.report(rows)
