"""How a name is written in B text: as it is where the lexer reads it whole as an identifier
(``x``, ``δ``, ``x₁′``), else back-quoted as ProB allows (```my name```, ```TRUE```).

The identifier's letters are the grammar's own (``ULETTER`` in ``grammar.lark``, ProB's
classes from BParser.scc), read from the grammar file so that the two never disagree.
"""

from __future__ import annotations

import functools
import re
from pathlib import Path

__all__ = ["name_text", "is_plain_name"]

_GRAMMAR = Path(__file__).with_name("grammar.lark")


@functools.lru_cache(maxsize=1)
def _syntax() -> tuple[re.Pattern, frozenset[str]]:
    text = _GRAMMAR.read_text(encoding="utf-8")
    letters = text[text.index("\nULETTER:"):text.index("\nPRIME:")]
    classes = "".join(re.findall(r"/\[(.*?)\]/", letters))
    letter = f"[{classes}]"
    plain = re.compile(f"(?:{letter}|_)(?:{letter}|λ|[0-9_])*[\u2080-\u2089]*"
                       f"[\u2032\u2018\u2019]*(?:\\$0)?")
    reserved = frozenset(re.findall(r'"([A-Za-z][A-Za-z0-9_]*)"', text))
    return plain, reserved


def is_plain_name(name: str) -> bool:
    """Whether ``name`` can be written as it is (an identifier, not a reserved word)."""
    plain, reserved = _syntax()
    return name not in reserved and plain.fullmatch(name) is not None


def name_text(name: str) -> str:
    """A name as B text: as it is, or back-quoted where it is not a plain identifier; a
    trailing ``'`` (``x'``, the value before a step) stays outside the quotes."""
    base, prime = (name[:-1], "'") if name.endswith("'") and len(name) > 1 else (name, "")
    if is_plain_name(base):
        return base + prime
    return "`" + base.replace("\\", "\\\\").replace("`", "\\`") + "`" + prime
