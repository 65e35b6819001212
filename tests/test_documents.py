"""The README's multiple-scattering figures are those scripts/multiple_scattering_docs.py writes
from its error table, the table docs/multiple_scattering.md shows."""

import importlib.util
from pathlib import Path

from tfm_addon.bench import readme

ROOT = Path(__file__).resolve().parents[1]


def _script():
    spec = importlib.util.spec_from_file_location("ms_docs", ROOT / "scripts" / "multiple_scattering_docs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_readme_s_multiple_scattering_figures_are_the_table_s():
    lines = (ROOT / "docs" / "multiple_scattering.md").read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("| medium | fitted on"))
    records = []
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        medium, _, n, s_ssim, s_ratio, m_ssim, m_ratio = (c.strip() for c in line.strip("|").split("|"))
        records.append((medium, int(n), (float(s_ssim), float(s_ratio)), (float(m_ssim), float(m_ratio))))
    assert len(records) > 50
    assert readme.block("multiple scattering").split() == _script().readme_sentence(records).split()
