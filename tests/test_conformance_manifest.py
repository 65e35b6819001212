"""The conformance manifest (tests/data/conformance/manifest.toml) names every row once with a valid
status and, for every status but 'rendered' and for a weak control, its reason; the documents'
counts are those the conformance page's writer made from the rows (docs/conformance.md, README)."""

import re

from tfm_addon.bench import conformance, readme

STATUSES = {"rendered", "reported", "wrong"}


def test_the_manifest_names_every_row_once_with_a_status_and_its_reasons():
    entries = conformance.manifest()
    ids = [r.id for r in conformance.ROWS]
    assert len(ids) == len(set(ids))
    assert set(entries) == set(ids), (set(ids) ^ set(entries))
    for row_id, entry in entries.items():
        status = entry.get("status")
        assert status in STATUSES, (row_id, status)
        allowed = {"status", "control", "control_reason"}
        if status == "reported":
            assert entry.get("report") and entry.get("reason"), row_id
            # its image is checked too: equal to its control's, or at its approximation's floor
            assert entry.get("same_as_control") is True or {"ssim", "brightness"} <= set(entry), row_id
            allowed |= {"report", "reason", "same_as_control", "ssim", "brightness"}
        elif status == "wrong":
            assert entry.get("reason"), row_id
            allowed |= {"reason"}
        if "control" in entry:
            assert entry["control"] == "weak" and entry.get("control_reason"), row_id
        assert set(entry) <= allowed, (row_id, set(entry) - allowed)
    # the suite's expectations are the manifest's
    for r in conformance.ROWS:
        assert r.expect == entries[r.id]["status"], r.id


def _page_counts() -> dict[str, int]:
    text = (readme.README.parent / "docs" / "conformance.md").read_text()
    today = re.search(r"^Today: (.*)\.$", text, re.M).group(1)
    return {k: int(v) for v, k in (part.split(" ", 1) for part in today.split(", "))}


def test_the_documents_count_every_row_and_agree():
    counts = _page_counts()
    statuses = [e["status"] for e in conformance.manifest().values()]
    assert sum(counts.values()) == len(conformance.ROWS)
    assert counts.get("reported", 0) == statuses.count("reported")
    assert counts.get("wrong", 0) == statuses.count("wrong")
    assert readme.block("conformance counts") == (f"{len(conformance.ROWS)} rows: "
                                                  f"{conformance.counts_text(counts)}")


def test_a_missing_reference_names_the_command_that_makes_it(tmp_path):
    import pytest

    with pytest.raises(FileNotFoundError, match="scripts/make_conformance_refs.py no_such_row"):
        conformance.load_reference("no_such_row", tmp_path)
    assert all((conformance.REF_DIR / f"{r.id}.npz").exists() for r in conformance.ROWS)
