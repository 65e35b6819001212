"""The conformance rows' negative controls (tfm_addon/bench/conformance.py, ``Row.control``).

A row's control is its scene with the row's subject set back to Blender's default; rendered by TFM it
must fail the row against the row's stored Cycles reference, or the row could not fail either. The
controls are rendered when the references are made (``scripts/make_conformance_refs.py --controls``
stores tests/data/conformance/<id>.control.json); these tests check that every row has one, made
from its current reference, that every stored control fails its row (but for the rows in
``conformance.WEAK_CONTROL``, whose control must not), and render a few controls again.
"""

import pytest

from tfm_addon.bench import conformance

ROWS = conformance.rows()
REMAKE = ".venv/bin/python scripts/make_conformance_refs.py --controls"

# cheap rows whose controls are rendered again: a node input, an object's visibility, a surface
LIVE = ("anisotropy_pos", "light_visible_diffuse_off", "surface_alpha_shadow")


def _figures(stored: dict) -> str:
    return (f"{stored['row']}'s control ({stored['control']}): SSIM {stored['ssim']:.4f}, brightness "
            + " / ".join(f"{q:.3f}" for q in stored["ratios"]))


def test_every_row_has_a_described_control():
    missing = [r.id for r in ROWS if r.control is None or not r.control_text]
    assert not missing, f"rows without a control or its description: {missing}"


def test_weak_controls_name_rows():
    unknown = sorted(set(conformance.WEAK_CONTROL) - set(conformance.ROW_BY_ID))
    assert not unknown, f"WEAK_CONTROL names no such rows: {unknown}"


@pytest.mark.parametrize("row", ROWS, ids=[r.id for r in ROWS])
def test_stored_control_is_of_the_current_reference(row):
    path = conformance.REF_DIR / f"{row.id}.control.json"
    assert path.exists(), f"{row.id} has no stored control: run {REMAKE} {row.id}"
    stored = conformance.load_control(row.id)
    assert stored["reference_sha1"] == conformance.reference_sha1(row.id), (
        f"{row.id}'s reference was remade after its control: run {REMAKE} {row.id}")
    assert stored["control"] == row.control_text, (
        f"{row.id}'s control changed since it was stored: run {REMAKE} {row.id}")


@pytest.mark.parametrize("row", ROWS, ids=[r.id for r in ROWS])
def test_stored_control_fails_its_row(row):
    stored = conformance.load_control(row.id)
    fails = not conformance.Comparison(stored["ssim"], tuple(stored["ratios"])).passes()
    assert fails == stored["fails"], f"the thresholds changed: run {REMAKE}; " + _figures(stored)
    if row.id in conformance.WEAK_CONTROL:
        assert not fails, ("the row's control now fails the row: delete the row from "
                           "conformance.WEAK_CONTROL; " + _figures(stored))
    else:
        assert fails, ("the row's control does not fail the row: the row cannot tell its setting "
                       "from Blender's default (find a stronger control, or say why in "
                       "conformance.WEAK_CONTROL); " + _figures(stored))


@pytest.mark.parametrize("row_id", LIVE)
def test_control_rendered_now_fails_its_row(blank, tmp_path, row_id):
    row = conformance.ROW_BY_ID[row_id]
    cycles, _ = conformance.load_reference(row.id)
    result = conformance.render_control(row, str(tmp_path))
    comparison = conformance.compare(row, result.image, cycles)
    figures = (f"{row.id}'s control ({row.control_text}): SSIM {comparison.ssim:.4f}, brightness "
               f"{comparison.ratio_text()}, report {result.messages}")
    print(figures)
    assert not comparison.passes(), figures
