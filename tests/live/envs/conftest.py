"""The built-in adapter a test module names (``ADAPTER = "highway-continuous"``), its
default shield's machine and one environment of it for the whole module."""

from __future__ import annotations

import pytest

from tracecheck.checking.shield import load_shield
from tracecheck.live.adapter import get_adapter


@pytest.fixture(scope="module")
def adapter(request):
    return get_adapter(request.module.ADAPTER)


@pytest.fixture(scope="module")
def shield(adapter):
    return load_shield(adapter.default_shield, actions=adapter.actions).machine


@pytest.fixture(scope="module")
def env(adapter):
    made = adapter.make_env(adapter.config())
    yield made
    made.close()
