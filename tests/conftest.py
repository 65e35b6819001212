"""Shared fixtures: one renderer (one GL context) for the whole session, on the main thread."""

import pytest

from tfm_addon.engine import Renderer


@pytest.fixture(scope="session")
def renderer():
    r = Renderer()
    yield r
    r.release()
