"""Located diagnostics: every problem a user can cause is reported as ``path:line:col: error: message``.

We own the error vocabulary (STYLE.md, point 4): the parser, the validator and the component expander all
report through :class:`Diagnostics`, which collects every problem of a run instead of stopping at the first,
and prints each with its source line and a caret under the offending span. A diagnostic raised inside an
instantiated library component carries the chain of instantiation sites as notes, as cairo-lang's
``Location.parent_location`` does.
"""

from __future__ import annotations

import bisect
import dataclasses
from dataclasses import dataclass, field
from typing import Iterable


@dataclass(frozen=True, eq=False)
class Source:
    """A text being compiled, with the path shown to the user (never resolved or rewritten)."""

    path: str
    text: str

    def line_text(self, line: int) -> str:
        lines = self._lines()
        return lines[line - 1] if 1 <= line <= len(lines) else ""

    def _lines(self) -> list[str]:
        cached = self.__dict__.get("_lines_cache")
        if cached is None:
            cached = self.text.split("\n")
            object.__setattr__(self, "_lines_cache", cached)
        return cached

    def position(self, offset: int) -> tuple[int, int]:
        """1-based (line, column) of a character offset (binary search in the line starts)."""
        starts = self.__dict__.get("_line_starts")
        if starts is None:
            starts = [0] + [i + 1 for i, c in enumerate(self.text) if c == "\n"]
            object.__setattr__(self, "_line_starts", starts)
        offset = max(0, min(offset, len(self.text)))
        line = bisect.bisect_right(starts, offset)
        return line, offset - starts[line - 1] + 1


@dataclass(frozen=True)
class Span:
    """A stretch of source text.

    ``via`` lists the component instantiations the text was seen through, innermost first, each as
    (label, span of the ``use`` statement), so an error inside a library file also points at its user.
    """

    source: Source = field(compare=False, repr=False)
    start: int
    end: int
    line: int
    col: int
    via: tuple[tuple[str, "Span"], ...] = field(default=(), compare=False, repr=False)

    @staticmethod
    def at(source: Source, start: int, end: int) -> "Span":
        line, col = source.position(start)
        return Span(source, start, max(end, start), line, col)

    def instantiated(self, label: str, site: "Span") -> "Span":
        """The same text, seen through one more (outer) component instantiation."""
        return dataclasses.replace(self, via=self.via + ((label, site),))

    @property
    def text(self) -> str:
        return self.source.text[self.start:self.end]


SEVERITIES = ("error", "warning", "note")


@dataclass(frozen=True)
class Diagnostic:
    severity: str
    message: str
    span: Span | None
    notes: tuple[tuple[str, Span | None], ...] = ()

    def render(self) -> str:
        out = [_render_one(self.severity, self.message, self.span)]
        for note, span in self.notes:
            out.append(_render_one("note", note, span))
        for label, site in (self.span.via if self.span else ()):
            out.append(_render_one("note", label, site))
        return "\n".join(out)


def _render_one(severity: str, message: str, span: Span | None) -> str:
    if span is None:
        return f"{severity}: {message}"
    head = f"{span.source.path}:{span.line}:{span.col}: {severity}: {message}"
    line = span.source.line_text(span.line)
    if not line.strip():
        return head
    line_end = span.start - (span.col - 1) + len(line)
    width = max(1, min(span.end, line_end) - span.start)
    shown = line.expandtabs(1).rstrip("\r")
    return f"{head}\n    {shown}\n    {' ' * (span.col - 1)}{'^' * width}"


class MbsError(Exception):
    """Raised to stop a stage; carries every diagnostic collected so far."""

    def __init__(self, diagnostics: Iterable[Diagnostic]):
        self.diagnostics = tuple(diagnostics)
        super().__init__("\n".join(d.render() for d in self.diagnostics))


class Diagnostics:
    """Collects diagnostics of one run; ``check()`` raises MbsError if any error was reported."""

    MAX_ERRORS = 100  # a garbage file would otherwise flood the terminal

    def __init__(self) -> None:
        self.items: list[Diagnostic] = []
        self._seen: set[tuple] = set()

    def error(self, message: str, span: Span | None, *notes: tuple[str, Span | None]) -> None:
        self._add(Diagnostic("error", message, span, tuple(notes)))

    def warning(self, message: str, span: Span | None, *notes: tuple[str, Span | None]) -> None:
        self._add(Diagnostic("warning", message, span, tuple(notes)))

    def note(self, message: str, span: Span | None) -> None:
        self._add(Diagnostic("note", message, span))

    def _add(self, diag: Diagnostic) -> None:
        key = (diag.severity, diag.message, diag.span.source.path if diag.span else None,
               diag.span.start if diag.span else None)
        if key in self._seen or self.error_count >= self.MAX_ERRORS:
            return
        self._seen.add(key)
        self.items.append(diag)

    @property
    def error_count(self) -> int:
        return sum(1 for d in self.items if d.severity == "error")

    @property
    def errors(self) -> list[Diagnostic]:
        return [d for d in self.items if d.severity == "error"]

    def check(self) -> None:
        if self.error_count:
            raise MbsError(self.items)

    def extend(self, diags: Iterable[Diagnostic]) -> None:
        for d in diags:
            self._add(d)

    def render(self) -> str:
        return "\n".join(d.render() for d in self.items)
