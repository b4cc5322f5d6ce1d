"""The public API reads like a library's: every function the façades export (tracecheck.b,
tracecheck.checking, tracecheck.episodes) and the extension points (EnvAdapter's hooks,
ShieldWrapper) have Google-style Args and Returns sections and an example; every exported
class a docstring."""

from __future__ import annotations

import importlib
import inspect

import pytest

FACADES = ("tracecheck.b", "tracecheck.checking", "tracecheck.episodes")


def _exported():
    for module in FACADES:
        mod = importlib.import_module(module)
        for name in mod.__all__:
            yield f"{module}.{name}", getattr(mod, name)


def missing_sections(obj) -> list[str]:
    """What a public function's or class's docstring lacks."""
    doc = inspect.getdoc(obj) or ""
    if inspect.isclass(obj):
        return [] if doc else ["a docstring"]
    parameters = [p for p in inspect.signature(obj).parameters if p not in ("self", "cls")]
    wanted = [("Args", not parameters or "Args:" in doc),
              ("Returns", "Returns:" in doc or "Yields:" in doc),
              ("an example", ">>>" in doc or "Example" in doc)]
    return [what for what, ok in wanted if not ok]


@pytest.mark.parametrize("name,obj", list(_exported()), ids=lambda v: v if isinstance(v, str)
                         else "")
def test_every_export_is_documented(name, obj):
    assert not missing_sections(obj), f"{name} lacks {', '.join(missing_sections(obj))}"


def test_the_extension_points_are_documented():
    from tracecheck.live.adapter import EnvAdapter
    from tracecheck.live.wrapper import ShieldWrapper

    assert "Example" in inspect.getdoc(EnvAdapter) and "Args:" in inspect.getdoc(ShieldWrapper)
    for hook in ("make_env", "state", "crashed", "scene", "plots", "training_settings"):
        doc = inspect.getdoc(getattr(EnvAdapter, hook))
        assert "Args:" in doc and "Returns:" in doc, hook


def test_the_check_finds_what_is_missing():
    def bare(x):
        """Does something."""

    assert missing_sections(bare) == ["Args", "Returns", "an example"]
