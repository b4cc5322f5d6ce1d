"""Pictures of episodes: a VisB-style viewer page and an HTML validation report; tables,
JSON and plots that are inert for their readers (docs/safety.md)."""

from __future__ import annotations

from .._lazy import lazy_names

__all__ = ["render_episode"]

# the viewer reads run files: imported on first use, so that tables and JSON stay light
__getattr__, __dir__ = lazy_names(__name__, {"render_episode": "viewer"}, globals())
