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
    assert by["flame strength"]["packed"] == [1]           # combined per voxel beside the density
    assert by["emission + blackbody"]["packed"] == [1]           # combined per voxel: one fetch
    assert by["emission + blackbody + colour grid"]["packed"] == [3]
    assert "Target: emission adds at most 10 %" in emission_bench.report(rows)


def test_emission_edit_row_times_edits_that_rebuild_nothing():
    rows = emission_bench.edit_rows(emission_bench.QUICK, log=lambda *_: None)
    assert [r["case"] for r in rows] == ["camera move"] + [name for name, _ in emission_bench.EDITS]
    assert all(r["seconds"] > 0 and r["rebuilt"] == 0 for r in rows)
    # One combination for the first frame, one per edit frame (the camera moves recompute none).
    assert rows[0]["combines"] == 1 + len(emission_bench.EDITS) * emission_bench.QUICK.repeats
    assert rows[0]["ratio"] == 1.0
    assert "at most 1.05" in emission_bench.edit_report(rows)
