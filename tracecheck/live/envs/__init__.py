"""tracecheck's own environments, one adapter module each (registered as entry points of
``tracecheck.environments`` in ``pyproject.toml``; ``tracecheck envs`` lists them)."""
