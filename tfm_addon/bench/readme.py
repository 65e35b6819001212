"""The README's figures written by the commands that measure them: a figure stands between marks
``<!-- name -->`` and ``<!-- /name -->``, and the command that measures it (the conformance page's
writer, the full benchmark's summary) replaces what stands there."""

from __future__ import annotations

from pathlib import Path

README = Path(__file__).resolve().parents[2] / "README.md"


def _marks(name: str) -> tuple[str, str]:
    return f"<!-- {name} -->", f"<!-- /{name} -->"


def block(name: str, text: str | None = None) -> str:
    """What the README says between the marks of ``name``."""
    text = README.read_text() if text is None else text
    start, end = _marks(name)
    return text[text.index(start) + len(start):text.index(end)]


def write_block(name: str, value: str) -> None:
    """Put ``value`` between the README's marks of ``name``."""
    text = README.read_text()
    start, end = _marks(name)
    README.write_text(text.replace(start + block(name, text) + end, start + value + end, 1))
