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
symmetric mass matrix's lower triangle) is copied right after its source, by the same part (ccode.py prints the
copies of the plan there). The results are the same to the
bit: every expression is printed and evaluated exactly as before, only where its value is kept changes.

Inside a part the statements come in the order of `part_order`: a carried temporary is read from carry right
before the first statement that needs it, stored right after it is computed, and an output is written right after
the last temporary of the part it reads. Printed with the reads at the top and the stores and outputs at the end,
every value lived through the whole part, and GCC's register allocation (IRA, LRA, the post-reload CSE and dead
stores over the spills) went superlinear in the live values: the Iltis's mass matrix part held 337 values live at
once, its largest part 548, and those two parts took 4 s of the model units' 11 s of CPU (bench/function_parts.py
--order measures it). GCC keeps the stores and loads where the text has them (out and carry may alias), so the
text's order is the order of the code.
"""

from __future__ import annotations

import functools
import itertools
import re
from dataclasses import dataclass

#: The characters of temporaries a part aims for. 20,000 before the statements were printed in part_order; with it,
#: parts of half that size cost the Iltis's model units a fifth less compiler CPU and its right-hand side no more
#: (bench/function_parts.py --order: 56,396 instructions against 57,009 at 20,000, the cuts at fewer live values;
#: 6,000 compiled no faster, in one unit more).
PART_CHARS = 10_000
#: A function is cut only when it is longer than this; shorter ones stay one function, as readable as before.
#: 30,000 as before the parts were halved: cutting the functions of 15,000 to 30,000 characters too saves the
#: Iltis's model units 4-7 % of their compiler CPU (`python bench/function_parts.py --order --split-baseline 15000`:
#: 7.71 against 7.23 s, 1.07; 1.04 in an earlier run) but grew a 10-link chain's file by 11 % in carries
#: (tests/compiler/test_ccode.py bounds its size), where no function compiles slowly.
SPLIT_CHARS = 30_000
_IDENTIFIER = re.compile(r"[A-Za-z_]\w*")


@functools.lru_cache(maxsize=1 << 16)
def names_in(text: str) -> frozenset[str]:
    """The identifiers a C expression's text mentions (numbers' exponents like the e of 1e-5 included: harmless,
    no temporary is called e); remembered, since the cuts, the parts and the statements' order each read every
    text of a long function."""
    return frozenset(_IDENTIFIER.findall(text))


#: A cut may move this fraction of a part's length away from where the length alone would put it, to where the
#: fewest temporaries are live (computed before, read after): each of those is a store and a load at run time.
CUT_WINDOW = 0.4


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
    cuts = _cuts(steps, results, part_chars)
    chunks = [list(steps[a:b]) for a, b in zip((0, *cuts), (*cuts, len(steps)))]
    if len(chunks) < 2:  # long outputs of few temporaries: nothing to gain
        return None
    home = {s.name: k for k, chunk in enumerate(chunks) for s in chunk}
    placed = [[] for _ in chunks]
    copies = []
    for k, value in results:
        if isinstance(value, int):
            copies.append((k, value))
            continue
        reads = [home[n] for n in names_in(value) if n in home]
        placed[max(reads, default=0)].append((k, value))
    needs = []
    for k, chunk in enumerate(chunks):
        texts = [s.text for s in chunk] + [s.guard for s in chunk if s.guard] + [v for _, v in placed[k]]
        needs.append({n for text in texts for n in names_in(text) if home.get(n, k) < k})
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


def _cuts(steps, results, part_chars: int) -> list[int]:
    """Indices of the steps that start a new part: about every part_chars characters of temporaries, each moved
    within CUT_WINDOW of that to where the fewest temporaries cross it (an output counts as read at the last
    temporary it reads, where it will be written)."""
    index = {s.name: k for k, s in enumerate(steps)}
    last = list(range(len(steps)))  # the last step (or output) that reads each step
    for k, step in enumerate(steps):
        for texts in (step.text, step.guard or ""):
            for n in names_in(texts):
                if n in index:
                    last[index[n]] = max(last[index[n]], k)
    for _, value in results:
        if not isinstance(value, int):
            reads = [index[n] for n in names_in(value) if n in index]
            for r in reads:
                last[r] = max(last[r], max(reads))
    change = [0] * (len(steps) + 2)  # crossing[c]: steps before c read at or after c (from its differences)
    for k, end in enumerate(last):
        change[k + 1] += 1
        change[end + 1] -= 1
    crossing = list(itertools.accumulate(change))
    start = [0]
    for step in steps:
        start.append(start[-1] + len(step.text) + (len(step.guard) if step.guard else 0))
    cuts, begin = [], 0
    while start[-1] - start[begin] > part_chars * (1 + CUT_WINDOW):
        low, high = start[begin] + part_chars * (1 - CUT_WINDOW), start[begin] + part_chars * (1 + CUT_WINDOW)
        target = start[begin] + part_chars
        window = ([c for c in range(begin + 1, len(steps)) if low <= start[c] <= high]
                  or [next(c for c in range(begin + 1, len(steps)) if start[c] >= low)])
        cut = min(window, key=lambda c: (crossing[c], abs(start[c] - target)))
        cuts.append(cut)
        begin = cut
    return cuts


def part_order(part: Part, results) -> list[tuple[str, object]]:
    """The statements of `part` in the order printed, as (kind, what): ("read", name) of an import, ("step", step),
    ("keep", name) of an export, ("write", (k, value)) of an output (`results`: the part's outputs with the copies
    after their sources, value an int for a copy). An import comes right before the first statement that reads it,
    an export right after its step, an output right after the last step of this part it reads (one that reads none
    first), a copy right after its source: each value lives from where it is computed to where it is last used,
    not across the part."""
    local = {s.name: k for k, s in enumerate(part.steps)}
    after: dict[int, list] = {}
    where: dict[int, int] = {}
    for k, value in results:
        if isinstance(value, int):
            at = where.get(value, -1)
        else:
            at = max((local[n] for n in names_in(value) if n in local), default=-1)
        where[k] = at
        after.setdefault(at, []).append(("write", (k, value)))
    exports = set(part.exports)
    for k, step in enumerate(part.steps):
        if step.name in exports:
            after.setdefault(k, []).insert(0, ("keep", step.name))
    items = after.get(-1, [])
    for k, step in enumerate(part.steps):
        items += [("step", step), *after.get(k, [])]
    rank = {name: k for k, name in enumerate(part.imports)}
    pending, order = set(part.imports), []
    for kind, what in items:
        if pending and kind != "keep" and not (kind == "write" and isinstance(what[1], int)):
            texts = (what.text, what.guard or "") if kind == "step" else (what[1],)
            due = pending.intersection(*[set().union(*map(names_in, texts))])
            order += [("read", name) for name in sorted(due, key=rank.__getitem__)]
            pending -= due
        order.append((kind, what))
    return order
