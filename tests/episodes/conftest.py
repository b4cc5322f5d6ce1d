"""Small hand-made episodes (made by tests/helpers.py's ``episode``)."""

from __future__ import annotations

import pytest

from tests.helpers import episode


@pytest.fixture
def episodes():
    return [episode(0), episode(1, 5, crash_at_end=True, live=True), episode(2, 1)]
