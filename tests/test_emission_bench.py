"""The emission benchmark row runs and times what it says: the same maps for every case, the
density packed where the case says."""

from tfm_addon.bench import emission_bench


def test_emission_row_rebuilds_nothing_while_timing():
    rows = emission_bench.run(emission_bench.QUICK, log=lambda *_: None)
    assert [r["case"] for r in rows] == [c[0] for c in emission_bench.CASES]
    assert all(r["seconds"] > 0 and r["rebuilt"] == 0 for r in rows)
    by = {r["case"]: r for r in rows}
    assert by["no emission"]["ratio"] == 1.0
    assert by["Quick Fire (blackbody grid)"]["packed"] == [1]
    assert by["Quick Fire, two fetches"]["packed"] == [0]
    assert by["flame strength"]["packed"] == [2]
    assert by["emission + blackbody"]["packed"] == [0]           # five values: two fetches
    assert by["emission + blackbody + colour grid"]["packed"] == [3]
    assert "Target: emission adds at most 10 %" in emission_bench.report(rows)
