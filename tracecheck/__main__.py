"""``python -m tracecheck``: the same as the ``tracecheck`` command."""

from .cli import main

if __name__ == "__main__":
    main()
