"""Pictures of episodes: a VisB-style viewer page and an HTML validation report."""

from .viewer import render_episode

__all__ = ["render_episode"]
