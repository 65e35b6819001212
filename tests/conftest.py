"""Shared fixtures: one renderer (one GL context) for the whole session, on the main thread, and
a fresh one per test for tests that count what it builds."""

import pytest

from tfm_addon.engine import Renderer


@pytest.fixture(scope="session")
def renderer():
    r = Renderer()
    yield r
    r.release()


@pytest.fixture
def fresh():
    r = Renderer()
    yield r
    r.release()
