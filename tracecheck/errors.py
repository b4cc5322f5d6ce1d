"""One error hierarchy for tracecheck (and the two warnings a damaged run file gives).

The library raises these; only the CLI turns them into exit codes and text. Every message
says where (file, line, column or episode/step), what was wrong and, where it helps, what to
do instead.
"""

from __future__ import annotations

__all__ = [
    "JoinedText",
    "TracecheckError",
    "BSyntaxError",
    "BTypeError",
    "BScopeError",
    "WellDefinednessError",
    "EvaluationError",
    "TimeLimitError",
    "SetLimitError",
    "UnsupportedError",
    "ModelError",
    "InputError",
    "Disagreement",
    "DamagedEpisode",
    "SalvagedEpisodeWarning",
    "did_you_mean",
    "closest",
]


def closest(name: str, names) -> "str | None":
    """The one of ``names`` nearest ``name`` as a misspelling (the same letters but for
    case, or difflib's ratio at least 0.75), else None.

    >>> closest("Gapp", ["Gap", "Speed"]), closest("Size", ["Gap", "Speed"])
    ('Gap', None)
    """
    import difflib

    names = [n for n in names if n != name]
    same = [n for n in names if n.lower() == name.lower()]
    found = same or difflib.get_close_matches(name, names, n=1, cutoff=0.75)
    return found[0] if found else None


def did_you_mean(name: str, names) -> str:
    """``did you mean X?`` for :func:`closest`, else ''.

    >>> did_you_mean("Gapp", ["Gap", "Speed"])
    'did you mean Gap?'
    """
    found = closest(name, names)
    return f"did you mean {found}?" if found else ""


def printable(text: str, keep: str = "\n") -> str:
    """``text`` with control characters (terminal escapes, NUL, …) shown as escapes: a
    message never lets an input file drive the terminal. Line breaks stay (and the other
    characters of ``keep``: a table cell keeps its tabs and carriage returns as data)."""
    if text.isprintable():
        return text
    probe = text
    for c in keep:  # at C speed: a large table or report is mostly printable
        probe = probe.replace(c, "")
    if probe.isprintable():
        return text
    return "".join(c if c.isprintable() or c in keep else repr(c)[1:-1] for c in text)


def caret_excerpt(source: str | None, line: int | None, column: int | None) -> str:
    """The source line at ``line`` with a caret under ``column`` (both 1-based)."""
    if not source or not line or line < 1:
        return ""
    lines = source.splitlines()
    if line > len(lines):
        return ""
    text = "".join(c if c.isprintable() else " " for c in lines[line - 1])
    col = max(1, column or 1)
    return f"\n    {text}\n    {' ' * (col - 1)}^"


class JoinedText(str):
    """Text joined from several files (a machine and the machines it sees and includes):
    an error placed in it is told in the file it came from, at that file's line."""

    parts: tuple[tuple[int, str | None, str], ...]  # (first line here, file, its text)

    def __new__(cls, parts: list[tuple[str | None, str]]) -> "JoinedText":
        out = super().__new__(cls, "\n".join(text for _, text in parts))
        first, placed = 1, []
        for file, text in parts:
            placed.append((first, file, text))
            first += text.count("\n") + 1
        out.parts = tuple(placed)
        return out

    def where(self, line: int) -> tuple[str | None, int, str]:
        """(file, line in it, its text) of ``line`` of the joined text."""
        first, file, text = next(p for p in reversed(self.parts) if p[0] <= line)
        return file, line - first + 1, text

    def __reduce__(self):  # to a worker process and back (a shield, an error placed in it)
        return JoinedText, ([(file, text) for _, file, text in self.parts],)


class TracecheckError(Exception):
    """Base class: every error tracecheck raises on bad input is one of these."""

    exit_code = 2

    def __init__(
        self,
        message: str,
        *,
        file: str | None = None,
        line: int | None = None,
        column: int | None = None,
        source: str | None = None,
        hint: str | None = None,
    ) -> None:
        self.message = message
        self.file = file
        self.line = line
        self.column = column
        self.source = source
        self.hint = hint
        self._place()
        super().__init__(self.render())

    def _place(self) -> None:
        """An error in a :class:`JoinedText`: its own file, line and text."""
        if isinstance(self.source, JoinedText) and self.line:
            file, self.line, self.source = self.source.where(self.line)
            self.file = file or self.file

    @property
    def location(self) -> str:
        parts = [self.file or "<input>"]
        if self.line:
            parts.append(str(self.line))
            if self.column:
                parts.append(str(self.column))
        return ":".join(parts)

    def render(self) -> str:
        text = printable(self.message)
        if self.file or self.line:
            text = f"{self.location}: {text}"
        text += caret_excerpt(self.source, self.line, self.column)
        if self.hint:
            text += f"\n  hint: {printable(self.hint)}"
        return text

    def located(self, *, file: str | None = None, source: str | None = None) -> "TracecheckError":
        """Fill in the file and source text where they are still unknown; returns self."""
        if file and not self.file:
            self.file = file
        if source and not self.source:
            self.source = source
        self._place()
        self.args = (self.render(),)
        return self

    def __str__(self) -> str:
        return self.render()

    def __reduce__(self):  # whole, with its place and hint, from a worker process
        return _restored, (type(self), dict(self.__dict__))


def _restored(cls: type, state: dict) -> "TracecheckError":
    error = cls.__new__(cls)
    error.__dict__.update(state)
    Exception.__init__(error, error.render())
    return error


class BSyntaxError(TracecheckError):
    """Text that is not B (or not the subset tracecheck reads)."""


class BScopeError(TracecheckError):
    """A name that is not declared, or declared twice."""


class BTypeError(TracecheckError):
    """A formula whose parts do not fit together: a predicate where an expression belongs,
    an integer compared with a real, a set used as a number."""


class WellDefinednessError(TracecheckError):
    """An expression without a value: a function applied outside its domain, min of an empty
    set, division by zero."""


class EvaluationError(TracecheckError):
    """Evaluation failed for a reason other than well-definedness (a variable without value,
    a set that cannot be enumerated)."""


class SetLimitError(EvaluationError):
    """A finite set too large to build or walk element by element."""


class TimeLimitError(EvaluationError):
    """tracecheck's own evaluation ran past a time limit (``--timeout``, ``--step-timeout``):
    it could not tell, which says nothing of the value — unknown, exit 3."""

    exit_code = 3


class UnsupportedError(TracecheckError):
    """Valid B that tracecheck does not evaluate (it says what to write instead)."""


class ModelError(TracecheckError):
    """A machine that parses but cannot be set up (unsatisfied PROPERTIES, cyclic
    definitions, duplicate operations)."""


class InputError(TracecheckError):
    """A bad command-line argument or input file that is not B text."""


class Disagreement(TracecheckError):
    """The solver and tracecheck's evaluator disagree on a counterexample (a bug)."""

    exit_code = 4


# ------------------------------------------------------------------ what is only warned


class DamagedEpisode(UserWarning):
    """A warning, not an error: a file whose tail is damaged (its complete episodes were
    read, the damaged one and the rest were lost)."""


class SalvagedEpisodeWarning(DamagedEpisode):
    """An episode left out because its parts do not agree (only when salvaging)."""
