"""tracecheck: validate reinforcement-learning agents and their B safety shields."""

__version__ = "0.1.0"

__all__ = ["__version__"]
