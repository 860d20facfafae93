"""Long generated functions printed as a chain of parts, so the C compiler's time grows with the code, not faster.

GCC's optimisers (register allocation, scheduling, value numbering with its alias walks) cost more than linearly in
the length of one straight-line function: the Iltis's mbs_loop_terms (2,900 temporaries, 350 kB of C) took 16 s of
CPU in one unit at -O2, most of the vehicle's compile. Cut into parts of about PART_CHARS characters of
temporaries, each part is a function of its own that the compiler builds in a fraction of that time, and the parts
of one function may go to different translation units that build in parallel (runtime/translation_units.py).

    int mbs_loop_terms_part1(double t, const double *x, const double *p, double *out, double *work, double *carry);
    ...
    int mbs_loop_terms(double t, const double *x, const double *p, double *out, double *work)
    {   double carry[N]; calls the parts in order, returns the first non-zero status, then the checks   }

A temporary that a later part reads is stored in `carry` (the parent's stack, N doubles) by the part that
computes it, and read back as a `const double` of the same name by the part that needs it: each part reads the same
names as the whole function did, so its text reads like the corresponding lines of the unsplit function. Each
output is written by the part that computes the last temporary it reads; an entry copied from another (a
symmetric mass matrix's lower triangle) is copied by the parent after all parts. The results are the same to the
bit: every expression is printed and evaluated exactly as before, only where its value is kept changes.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

#: The characters of temporaries a part aims for (bench/compile_time.py --part-chars measures the trade-off).
PART_CHARS = 20_000
#: A function is cut only when it is longer than this; shorter ones stay one function, as readable as before.
SPLIT_CHARS = 3 * PART_CHARS // 2
_IDENTIFIER = re.compile(r"[A-Za-z_]\w*")


def names_in(text: str) -> set[str]:
    """The identifiers a C expression's text mentions (numbers' exponents like the e of 1e-5 included: harmless,
    no temporary is called e)."""
    return set(_IDENTIFIER.findall(text))


@dataclass(frozen=True)
class Part:
    """One part: its temporaries (steps), the outputs it writes ((k, text)), the names it reads from earlier parts
    (imports) and those it leaves to later ones (exports), each with its slot in carry."""

    steps: tuple
    results: tuple
    imports: tuple
    exports: tuple


def plan_parts(steps, results, part_chars: int | None = None, split_chars: int | None = None
               ) -> tuple[tuple[Part, ...], dict[str, int], tuple] | None:
    """(parts, carry slot of each carried name, the copied entries (k, j) the parent writes), or None when the
    function is short enough to stay whole (its temporaries and outputs under split_chars characters)."""
    part_chars = PART_CHARS if part_chars is None else part_chars
    split_chars = SPLIT_CHARS if split_chars is None else split_chars
    length = sum(len(s.text) for s in steps) + sum(len(v) for _, v in results if not isinstance(v, int))
    if length <= split_chars or len(steps) < 2:
        return None
    chunks, size = [[]], 0
    for step in steps:
        if size >= part_chars:
            chunks.append([])
            size = 0
        chunks[-1].append(step)
        size += len(step.text) + (len(step.guard) if step.guard else 0)
    if len(chunks) < 2:  # long outputs of few temporaries: nothing to gain
        return None
    home = {s.name: k for k, chunk in enumerate(chunks) for s in chunk}
    placed = [[] for _ in chunks]
    copies = []
    for k, value in results:
        if isinstance(value, int):
            copies.append((k, value))
            continue
        reads = [home[n] for n in _IDENTIFIER.findall(value) if n in home]
        placed[max(reads, default=0)].append((k, value))
    needs = []
    for k, chunk in enumerate(chunks):
        texts = [s.text for s in chunk] + [s.guard for s in chunk if s.guard] + [v for _, v in placed[k]]
        needs.append({n for text in texts for n in _IDENTIFIER.findall(text) if home.get(n, k) < k})
    slots: dict[str, int] = {}
    for name in (s.name for s in steps):
        if any(name in need for need in needs):
            slots[name] = len(slots)
    parts = []
    for k, chunk in enumerate(chunks):
        exports = tuple(s.name for s in chunk if s.name in slots)
        imports = tuple(n for n in slots if n in needs[k])
        parts.append(Part(tuple(chunk), tuple(placed[k]), imports, exports))
    return tuple(parts), slots, tuple(copies)
