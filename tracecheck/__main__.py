"""``python -m tracecheck``: the same as the ``tracecheck`` command."""

from .cli import main

main()
