"""tracecheck's data, installed as ``tracecheck.models``: the built-in shields, the bundled
agents with their model cards, and example states (read with :func:`tracecheck.checking.shield.data_dir`)."""
