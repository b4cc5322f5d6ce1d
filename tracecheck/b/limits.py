"""The interpreter limits the B engine works under: how many decimal digits an integer may
have when it is read or printed."""

from __future__ import annotations

import sys

__all__ = ["MAX_DIGITS", "read_int"]

#: Integers up to this many decimal digits are read and printed — every integer the engine
#: computes has fewer (powers are capped at 10**6 bits, about 301 030 digits); a longer
#: literal is refused with its place. Python's own default limit (4300) is raised to it.
MAX_DIGITS = 310_000
if 0 < sys.get_int_max_str_digits() < MAX_DIGITS:
    sys.set_int_max_str_digits(MAX_DIGITS)


def read_int(text: str) -> int:
    """The integer written in ``text`` (a ``ValueError`` saying so above :data:`MAX_DIGITS`)."""
    if len(text) > MAX_DIGITS + 1:
        raise ValueError(f"an integer of {len(text.lstrip('-'))} digits is longer than the "
                         f"{MAX_DIGITS} digits tracecheck reads")
    return int(text)
