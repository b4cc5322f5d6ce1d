"""``python -m tracecheck.cli``: the same as the ``tracecheck`` command."""

from . import main

main()
