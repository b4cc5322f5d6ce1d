"""ProB's ``LibraryRegex.def``: ECMAScript regular expressions (ProB runs them with the C++
standard library) over B strings, here with Python's :mod:`re` after a translation that
keeps ECMAScript's meaning or refuses.

What the translation does, and why (ProB's notebook ``ExternalFunctions.ipynb`` documents the
functions and their Unicode treatment):

* strings and patterns are sequences of Unicode characters (ProB reads them as UTF-8): ``.``
  is one character, positions and lengths count characters;
* ``.`` matches anything but the line terminators LF, CR, U+2028 and U+2029; ``^`` and ``$``
  are the ends of the whole string (Python's ``$`` also matches before a final newline);
* ``[[:alpha:]]`` and the other POSIX classes, which ProB's examples show matching letters
  such as ``ä``: the class is spelled out as the characters of the subject string that have
  the property (a pattern only ever looks at those), plus the ASCII ones;
* ``\\d \\w \\s \\b`` and their negations are ECMAScript's ASCII classes where the subject is
  ASCII; with other characters in the subject they are refused (how ProB's C++ library
  classifies them is not documented);
* a replacement's ``$0``..``$9``, ``$&``, ``$$``, ``$``` and ``$'`` as ECMAScript (ProB's
  example: ``$0`` is the whole match); anything else after ``$`` is refused;
* what Python and ECMAScript read differently — lookbehind (ProB refuses it too), named
  groups, inline flags, ``\\c``, ``\\u{…}``, a search or a replacement with an empty match —
  is refused, never guessed.
"""

from __future__ import annotations

import re
from typing import Any

from .btypes import BOOL, INTEGER, STRING, Pow, Prod, Rec
from .values import Record, sequence

__all__ = ["regex_functions", "BadPattern", "Unsupported"]


class BadPattern(Exception):
    """The pattern is not an ECMAScript regular expression."""


class Unsupported(Exception):
    """The pattern or call means something tracecheck does not reproduce exactly."""


_POSIX = {
    "alpha": str.isalpha, "digit": lambda c: "0" <= c <= "9", "alnum": str.isalnum,
    "upper": str.isupper, "lower": str.islower, "space": str.isspace,
    "xdigit": lambda c: c in "0123456789abcdefABCDEF",
    "punct": lambda c: c.isascii() and not c.isalnum() and c.isprintable() and c != " ",
}
#: ECMAScript's classes on ASCII text (Python's \\s would also take U+001C-U+001F)
_ASCII_CLASSES = {"d": "[0-9]", "D": "[^0-9]", "w": "[A-Za-z0-9_]", "W": "[^A-Za-z0-9_]",
                  "s": "[\\t\\n\\v\\f\\r ]", "S": "[^\\t\\n\\v\\f\\r ]",
                  "b": "\\b", "B": "\\B"}
#: … and inside a character class (where a negated one cannot be written)
_IN_CLASS = {"d": "0-9", "w": "A-Za-z0-9_", "s": "\\t\\n\\v\\f\\r "}
_CONTROL = {"t": "\t", "n": "\n", "v": "\v", "f": "\f", "r": "\r", "0": "\0"}
_DOT = "[^\\n\\r\\u2028\\u2029]"


def _class_chars(name: str, subject: str) -> str:
    test = _POSIX.get(name)
    if test is None:
        raise Unsupported(f"the character class [:{name}:]")
    chars = {c for c in subject if test(c)}
    chars |= {chr(k) for k in range(128) if test(chr(k))}
    return "".join(re.escape(c) if c not in "-" else "\\-" for c in sorted(chars))


class _Frame:
    """An open group while translating: the capturing groups inside it, whether a branch
    (``|``) splits it, whether it is a lookahead, and whether it holds a quantifier."""

    def __init__(self, lookahead: bool = False) -> None:
        self.groups: list[int] = []
        self.branches = False
        self.lookahead = lookahead
        self.quantified = False


_QUANTIFIER = re.compile(r"[*+?]|\{(\d+)(,(\d*))?\}")


def translate(pattern: str, subject: str, search: bool = False) -> tuple[str, frozenset]:
    """(the Python pattern that means what the ECMAScript ``pattern`` means on ``subject``,
    the capturing groups that may take part in no match, or match more than once: under a
    quantifier, in one branch of a ``|``, in a lookahead — where ECMAScript and Python keep
    different captures). ``search``: the pattern is tried from every position (refused where
    that could backtrack too long, see :func:`_backtracking`)."""
    out: list[str] = []
    i, n, groups = 0, len(pattern), 0
    frames = [_Frame()]
    unsure: set[int] = set()
    backrefs: list[int] = []
    atom = False  # something a quantifier may follow was just written
    variable = 0  # quantifiers of variable width: each a choice backtracking may revisit
    ascii_subject = subject.isascii()
    while i < n:
        c = pattern[i]
        m = _QUANTIFIER.match(pattern, i)
        if m:
            if not atom:
                raise BadPattern(f"nothing to repeat at {m.group(0)!r}")
            out.append(m.group(0))
            fixed = m.group(1) is not None and (m.group(2) is None or m.group(3) == m.group(1))
            if not fixed:  # *, +, ?, {n,}, {n,m}: a choice backtracking may revisit
                variable += 1
            i = m.end()
            if pattern.startswith("?", i):  # lazy
                out.append("?")
                i += 1
            if _QUANTIFIER.match(pattern, i):
                raise Unsupported("a quantifier right after a quantifier (Python reads "
                                  "a*+ as possessive)")
            frames[-1].quantified = True
            atom = False
            continue
        if c == "{":
            raise Unsupported("a '{' that is not a quantifier {n}, {n,} or {n,m}")
        atom = True
        if c == "\\":
            i, piece, ref = _escape(pattern, i, ascii_subject)
            out.append(piece)
            if ref:
                backrefs.append(ref)
            continue
        if c == "[":
            i, piece = _bracket(pattern, i, subject, ascii_subject)
            out.append(piece)
            continue
        if c == "(":
            atom = False
            if pattern.startswith("(?", i):
                if pattern.startswith(("(?:", "(?=", "(?!"), i):
                    frames.append(_Frame(lookahead=pattern[i + 2] in "=!"))
                    out.append(pattern[i:i + 3])
                    i += 3
                    continue
                if pattern.startswith(("(?<=", "(?<!"), i):
                    raise Unsupported("lookbehind (ProB does not support it either)")
                raise Unsupported(f"the group {pattern[i:i + 3]!r}")
            groups += 1
            frames.append(_Frame())
            frames[-1].groups.append(groups)
            out.append("(")
        elif c == ")":
            if len(frames) == 1:
                raise BadPattern("an unmatched ')'")
            done = frames.pop()
            following = _QUANTIFIER.match(pattern, i + 1)
            if done.branches or done.lookahead or following:
                unsure.update(done.groups)
            if following and (done.quantified or done.branches):
                raise Unsupported("a repeated group that holds a quantifier or a '|' (its "
                                  "matching can take exponential time)")
            frames[-1].groups.extend(done.groups)
            out.append(")")
        elif c == "|":
            frames[-1].branches = True
            atom = False
            out.append("|")
        elif c == ".":
            out.append(_DOT)
        elif c == "^":
            out.append("\\A")
            atom = False
        elif c == "$":
            out.append("\\Z")
            atom = False
        elif c in "}]":
            out.append("\\" + c)
        else:
            out.append(re.escape(c))
        i += 1
    if len(frames) > 1:
        raise BadPattern("an unclosed '('")
    if frames[0].branches:
        unsure.update(frames[0].groups)
    for k in backrefs:
        if k > groups:
            raise BadPattern(f"\\{k} refers to a group the pattern does not have")
        if k in unsure:
            raise Unsupported(f"\\{k} refers to a group that may take part in no match or "
                              "in several (ECMAScript and Python differ there)")
    _backtracking(variable + search, subject)  # a search tries each start as well
    return "".join(out), frozenset(unsure)


#: The most steps a match may take by the bound below: Python's re cannot be interrupted
#: (no --timeout reaches it), so a pattern that could take longer is refused before it runs
BACKTRACK_STEPS = 10 ** 8


def _backtracking(variable: int, subject: str) -> None:
    """Refuse a pattern whose ``variable`` repetitions could backtrack past
    :data:`BACKTRACK_STEPS` on ``subject``: with k of them a failing match may try every
    way of splitting n characters among them, about (n + 1)^k (``.*`` eight times then
    ``x``; ``a?`` forty times then ``a`` forty times). Repeated groups that hold a
    quantifier are refused by :func:`translate` already."""
    if variable >= 2 and (len(subject) + 1) ** variable > BACKTRACK_STEPS:
        raise Unsupported(f"a pattern with {variable} repetitions of variable width (a "
                          f"search's start counts as one), on a "
                          f"string of {len(subject)} characters, can take about "
                          f"{len(subject) + 1}^{variable} steps to fail; tracecheck refuses "
                          f"matches that could take over {BACKTRACK_STEPS:.0e} (Python's "
                          "regular expressions cannot be interrupted)")


def _escape(pattern: str, i: int, ascii_subject: bool) -> tuple[int, str, int]:
    """(the index after the escape at ``pattern[i]``, its Python form, the group it refers
    to or 0)."""
    if i + 1 >= len(pattern):
        raise BadPattern("a '\\' at the end of the pattern")
    e = pattern[i + 1]
    if e in _ASCII_CLASSES:
        if not ascii_subject:
            raise Unsupported(f"\\{e} on a string with characters beyond ASCII (how ProB's C++ "
                              "library classifies them is not documented)")
        return i + 2, _ASCII_CLASSES[e], 0
    if e.isdigit() and e != "0":
        if i + 2 < len(pattern) and pattern[i + 2].isdigit():
            raise Unsupported("a back-reference of two digits")
        return i + 2, "\\" + e, int(e)
    if e in _CONTROL:
        if e == "0" and i + 2 < len(pattern) and pattern[i + 2].isdigit():
            raise Unsupported("\\0 followed by a digit")
        return i + 2, re.escape(_CONTROL[e]), 0
    if e == "x":
        m = re.match(r"[0-9a-fA-F]{2}", pattern[i + 2:])
        if not m:
            raise BadPattern("\\x needs two hexadecimal digits")
        return i + 4, re.escape(chr(int(m.group(0), 16))), 0
    if e == "u":
        m = re.match(r"[0-9a-fA-F]{4}", pattern[i + 2:])
        if not m:
            raise Unsupported("\\u without four hexadecimal digits")
        return i + 6, re.escape(chr(int(m.group(0), 16))), 0
    if e.isalnum():
        raise Unsupported(f"the escape \\{e}")
    return i + 2, re.escape(e), 0  # an escaped punctuation character: itself


def _bracket(pattern: str, i: int, subject: str, ascii_subject: bool) -> tuple[int, str]:
    """``[...]`` from ``pattern[i]``: (the index after it, its Python form)."""
    out = ["["]
    i += 1
    if pattern.startswith("^", i):
        out.append("^")
        i += 1
    start = i
    while True:
        if i >= len(pattern):
            raise BadPattern("an unclosed '['")
        c = pattern[i]
        if c == "]" and i > start:
            out.append("]")
            return i + 1, "".join(out)
        if c == "]":  # ECMAScript: [] matches nothing, [^] anything
            raise Unsupported("an empty character class")
        if pattern.startswith("[:", i) or (c == "\\" and pattern[i + 1:i + 2] in _IN_CLASS):
            # a class of characters: never the end of a range
            end = pattern.find(":]", i + 2) + 2 if c == "[" else i + 2
            if c == "[" and end < 4:
                raise BadPattern("an unclosed '[:'")
            if (i - 1 > start and pattern[i - 1] == "-") or \
                    (pattern.startswith("-", end) and not pattern.startswith("-]", end)):
                raise Unsupported("a range with a class of characters at one end")
            if c == "[":
                out.append(_class_chars(pattern[i + 2:end - 2], subject))
            else:
                if not ascii_subject:
                    raise Unsupported(f"\\{pattern[i + 1]} on a string with characters beyond "
                                      "ASCII (how ProB's C++ library classifies them is not "
                                      "documented)")
                out.append(_IN_CLASS[pattern[i + 1]])
            i = end
            continue
        if c == "[":
            if pattern.startswith(("[.", "[="), i):
                raise Unsupported("collating elements and equivalence classes")
            out.append("\\[")
        elif c == "\\":
            if pattern[i + 1:i + 2] in ("D", "W", "S", "b", "B") or \
                    pattern[i + 1:i + 2].isdigit() and pattern[i + 1] != "0":
                raise Unsupported(f"\\{pattern[i + 1]} inside a character class")
            i, piece, _ = _escape(pattern, i, ascii_subject)
            out.append(piece)
            continue
        elif c in "&~|" and pattern.startswith(c * 2, i):
            out.append("\\" + c)  # Python reads a doubled one as a set operation
        else:
            out.append(c)
        i += 1


def _compile(pattern: str, subject: str, search: bool = False
             ) -> tuple["re.Pattern", frozenset]:
    python, unsure = translate(pattern, subject, search)
    try:
        return re.compile(python), unsure
    except re.error as exc:
        raise BadPattern(str(exc)) from None
    except (OverflowError, RecursionError):
        raise Unsupported("a repetition count or nesting too large for Python's re") from None


def _match(s: str, p: str) -> bool:
    return _compile(p, s)[0].fullmatch(s) is not None


def _is_regex(p: str) -> bool:
    try:
        _compile(p, "")
    except BadPattern:
        return False
    return True


def _all_matches(s: str, p: str, start: int = 0) -> list:
    found = list(_compile(p, s, search=True)[0].finditer(s, start))
    if any(m.end() == m.start() for m in found):
        raise Unsupported("a pattern that matches the empty string here (where the next "
                          "search starts after an empty match differs between libraries)")
    return found


def _replace(s: str, p: str, r: str) -> str:
    matches = _all_matches(s, p)
    unsure = _compile(p, s, search=True)[1]
    out, last, size = [], 0, len(s)
    for m in matches:
        out.append(s[last:m.start()])
        out.append(_substitute(r, m, s, unsure))
        size += len(out[-1]) - (m.end() - m.start())
        if size > MAX_RESULT:  # before the next one is built
            raise Unsupported(f"REGEX_REPLACE would build a string of over {MAX_RESULT:,} "
                              "characters")
        last = m.end()
    out.append(s[last:])
    return "".join(out)


#: The longest string a replacement builds (the string library's limit)
MAX_RESULT = 16 * 1024 * 1024


def _substitute(r: str, m: "re.Match", s: str, unsure: frozenset) -> str:
    out, i = [], 0
    while i < len(r):
        c = r[i]
        if c != "$":
            out.append(c)
            i += 1
            continue
        nxt = r[i + 1:i + 2]
        if nxt == "$":
            out.append("$")
        elif nxt == "&":
            out.append(m.group(0))
        elif nxt == "`":
            out.append(s[:m.start()])
        elif nxt == "'":
            out.append(s[m.end():])
        elif nxt.isdigit() and r[i + 2:i + 3].isdigit():
            raise Unsupported(f"a two-digit group reference ${r[i + 1:i + 3]} in the "
                              "replacement (ECMAScript reads it by the groups there are)")
        elif nxt.isdigit():
            k = int(nxt)
            if k > (m.re.groups or 0):
                raise Unsupported(f"${k} names a group the pattern does not have")
            if k in unsure:
                raise Unsupported(f"${k} names a group that may take part in no match or in "
                                  "several (ECMAScript and Python differ there)")
            out.append(m.group(k) or "")
        else:
            raise Unsupported(f"the replacement {r!r} ($ followed by {nxt!r})")
        i += 2
    return "".join(out)


def _search_str(s: str, p: str) -> str:
    m = _compile(p, s, search=True)[0].search(s)
    return m.group(0) if m else ""


def _search(s: str, start: int, p: str) -> Record:
    if not 1 <= start <= len(s) + 1:
        raise Unsupported(f"a search from position {start} of a string of {len(s)} characters")
    if start > 1 and re.search(r"\^|\\[bB]", p):
        raise Unsupported("^ or \\b in a search that does not start at the beginning")
    compiled, unsure = _compile(p, s, search=True)
    if unsure:
        raise Unsupported("submatches of a group that may take part in no match or in "
                          "several (ECMAScript and Python differ there)")
    m = compiled.search(s, start - 1)
    if m is None:
        return Record([("length", -1), ("position", -1), ("string", ""),
                       ("submatches", frozenset())])
    groups = m.groups()
    if any(g is None for g in groups):
        raise Unsupported("a group that took part in no match")
    return Record([("length", m.end() - m.start()), ("position", m.start() + 1),
                   ("string", m.group(0)), ("submatches", sequence(list(groups)))])


def _search_all(s: str, p: str) -> Any:
    return sequence([m.group(0) for m in _all_matches(s, p)])


def regex_functions(function, sig, undefined, refused) -> dict:
    """The functions of LibraryRegex.def as ``library.Function`` s (``function``: its class,
    ``sig`` its signature helper; a :class:`BadPattern` is ``undefined``, an
    :class:`Unsupported` ``refused``)."""
    def guarded(fn):
        def call(*args):
            try:
                return fn(*args)
            except BadPattern as exc:
                raise undefined(f"not a regular expression: {exc}") from None
            except Unsupported as exc:
                raise refused(str(exc)) from None
        return call

    S, Z = STRING, INTEGER
    seq_s = Pow(Prod(INTEGER, STRING))
    found = Rec((("length", Z), ("position", Z), ("string", S), ("submatches", seq_s)))
    return {
        "REGEX_MATCH": function("REGEX_MATCH", sig(S, S, BOOL), guarded(_match),
                                predicate=True),
        "IS_REGEX": function("IS_REGEX", sig(S, BOOL), guarded(_is_regex), predicate=True),
        "REGEX_REPLACE": function("REGEX_REPLACE", sig(S, S, S, S), guarded(_replace)),
        "REGEX_SEARCH_STR": function("REGEX_SEARCH_STR", sig(S, S, S), guarded(_search_str)),
        "REGEX_SEARCH": function("REGEX_SEARCH", sig(S, Z, S, found), guarded(_search)),
        "REGEX_SEARCH_ALL": function("REGEX_SEARCH_ALL", sig(S, S, seq_s),
                                     guarded(_search_all)),
    }
