"""The fuzz harness's generator and runner: random valid models through check, derivation, code generation and a
short simulation, and mutated models through check. Every outcome must be a result or a located error, never an
internal error, a crash or a hang; the outcomes are counted by kind for the table the tests print.

Models start from tests/physics/randmodel.py (random trees with every joint kind, rotated frames, joints written
child to parent) and are then changed the ways that broke the layers behind the front end: parts made massless,
loops closed between random parts, springs added, coordinates prescribed, masses, inertias and gravity scaled to
extremes.
"""

from __future__ import annotations

import re
import signal
import sys
from collections import Counter
from contextlib import contextmanager
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "physics"))
import randmodel  # noqa: E402

import mbs  # noqa: E402
from mbs.language.diagnostics import MbsError  # noqa: E402
from mbs.language.frontend import check_text  # noqa: E402

#: Seconds one model may take through every stage before it counts as a hang.
HANG_SECONDS = 120
#: Simulated seconds of the short run.
T_END = 0.05
#: Steps of the short run before it counts as failed (extreme models need millions: a result all the same).
MAX_STEPS = 20_000

NUMBER = re.compile(r"[-+]?\d[\d.]*(e[-+]?\d+)?")
BODY = re.compile(r"rigid (p\d+) \{\n        body \{\n.*?\n        \}\n", re.DOTALL)


class Hang(Exception):
    """A model took longer than HANG_SECONDS."""


@contextmanager
def time_limit(seconds: float):
    def expire(signum, frame):
        raise Hang()
    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def _parts(text: str) -> list[str]:
    return re.findall(r"(?:rigid|part) (p\d+) \{", text)


def random_valid_model(rng: np.random.Generator, loops: float = 0.15) -> tuple[str, set[str]]:
    """(model text, tags saying what was done to it); `loops`: the probability of closing a loop."""
    n = int(rng.integers(2 if loops >= 1 else 1, 4))
    text, _, _ = randmodel.random_model(rng, n, name="fuzz", flip_probability=0.3)
    tags = set()
    parts = _parts(text)
    extra = []
    if rng.random() < 0.25:  # a massless part (a located error unless held by a loop or prescribed motion)
        victim = parts[int(rng.integers(len(parts)))]
        text = re.sub(rf"rigid {victim} \{{\n        body \{{\n.*?\n        \}}\n", f"part {victim} {{\n", text,
                      count=1, flags=re.DOTALL)
        tags.add("massless")
    if rng.random() < 0.3:  # extreme parameters
        scale = 10.0 ** float(rng.choice([-12, -6, 6, 12]))
        what = rng.choice(["mass", "inertia", "gravity"])
        if what == "mass":
            text = re.sub(r"mass = ([-0-9.e]+) kg", lambda m: f"mass = {float(m.group(1)) * scale!r} kg", text)
        elif what == "inertia":
            text = re.sub(r"inertia = (\[\[.*?\]\]) kg\*m\^2", lambda m: "inertia = " + NUMBER.sub(
                lambda x: repr(float(x.group(0)) * scale), m.group(1)) + " kg*m^2", text)
        else:
            text = text.replace("model fuzz {\n", f"model fuzz {{\n    gravity = (0, 0, {-9.81 * scale!r}) m/s^2\n", 1) \
                if "gravity =" not in text else re.sub(r"gravity = \(([^)]*)\)",
                                                       lambda m: f"gravity = ({m.group(1)}) * {scale!r}", text)
        tags.add(f"extreme {what}")
    if rng.random() < 0.25:  # a prescribed coordinate
        match = re.search(r"joint (revolute|prismatic)\(axis = [^)]*\)\n", text)
        if match:
            coordinate, unit = ("phi", "rad") if match.group(1) == "revolute" else ("s", "m")
            text = text[:match.end() - 1] + f" {{\n            prescribe {coordinate} = 0.3 {unit} * sin(5 * t / 1 s)\n" \
                   "        }\n" + text[match.end():]
            tags.add("prescribed")
    if rng.random() < 0.3:  # a spring between two random parts
        a, b = rng.choice(["inertial", *parts], size=2, replace=False)
        extra.append(f"    interact spring_{len(extra)} {{\n        connect {a} -> {b}\n"
                     "        force f = spring_damper(k = 1000 N/m, d = 10 N*s/m, l0 = 0.1 m)\n    }\n")
        tags.add("spring")
    if rng.random() < loops and len(parts) >= 2:  # a closed loop
        a, b = rng.choice(["inertial", *parts], size=2, replace=False)
        kind = rng.choice(["spherical(rotation = cardan)", "universal(axis1 = x, axis2 = y)", "planar",
                           "cylindrical(axis = z)"])
        extra.append(f"    interact loop_{len(extra)} {{\n        connect {a} -> {b}\n        joint {kind}\n    }}\n")
        tags.add("loop")
    text = text[: text.rstrip().rfind("}")] + "".join(extra) + "}\n"
    return text, tags or {"plain"}


TOKENS = ["{", "}", "(", ")", ",", "=", "->", ".", "m", "kg", "-", "^", "*", "/", "0", "1e308", "1e-300", "nan",
          "rigid", "part", "body", "frame", "interact", "connect", "joint", "free", "revolute", "cut = true", "\n",
          "mass = ", "inertia = diag(0, 0, 0) kg*m^2", "prescribe phi = t", "p0", "inertial", "(0, 0, 0)"]


def mutate(rng: np.random.Generator, text: str) -> str:
    for _ in range(int(rng.integers(1, 5))):
        pos = int(rng.integers(0, max(1, len(text))))
        action = rng.choice(["delete", "insert", "duplicate", "swap"])
        if action == "delete":
            text = text[:pos] + text[pos + int(rng.integers(1, 20)):]
        elif action == "insert":
            text = text[:pos] + str(rng.choice(TOKENS)) + text[pos:]
        elif action == "duplicate":
            end = pos + int(rng.integers(1, 60))
            text = text[:end] + text[pos:end] + text[end:]
        else:
            number = re.search(r"-?\d+\.\d+", text[pos:])
            if number:
                a, b = pos + number.start(), pos + number.end()
                text = text[:a] + str(rng.choice(["0", "-1", "1e300", "1e-300", "0.0"])) + text[b:]
    return text


def _located(err: MbsError) -> bool:
    errors = [d for d in err.diagnostics if d.severity == "error"]
    return bool(errors) and all(d.span is not None for d in errors) and all(d.render() for d in errors)


def run_valid(text: str, backend: str) -> str:
    """The outcome of a valid model through every stage (raises on an internal error or a hang)."""
    with time_limit(HANG_SECONDS):
        try:
            system = mbs.loads(text, path="fuzz.mbs", backend=backend)
        except MbsError as err:
            if not _located(err):
                raise AssertionError(f"unlocated check error: {[d.render() for d in err.diagnostics]}") from None
            return "located error at check"
        try:
            res = system.simulate(t_end=T_END, sample=T_END / 5, max_wall_time=HANG_SECONDS / 2, max_steps=MAX_STEPS)
        except MbsError as err:
            rendered = [d.render() for d in err.diagnostics]
            assert rendered and all(rendered), rendered
            return "located error after check" if _located(err) else "error message (run)"
    if res.success:
        return "result"
    assert res.message, "a failed run without a message"
    return "failed run: " + NUMBER.sub("#", res.message.split(":")[0])[:60]


def run_mutated(text: str) -> str:
    with time_limit(HANG_SECONDS):
        try:
            check_text(text, "fuzz.mbs")
        except MbsError as err:
            if not _located(err):
                raise AssertionError(f"unlocated check error: {[d.render() for d in err.diagnostics]}") from None
            return "mutated: located error"
    return "mutated: accepted"


def campaign(seed: int, valid: int, mutated: int, c_every: int = 0, loops: bool = True,
             force_loops: bool = False) -> tuple[Counter, list]:
    """Run `valid` random models through the pipeline (every `c_every`-th, and every loop, on the C back end;
    the rest on NumPy) and `mutated` mutations through check. Returns (outcome counts, failures)."""
    loop_probability = 1.0 if force_loops else (0.15 if loops else 0.0)
    rng = np.random.default_rng(seed)
    outcomes, failures = Counter(), []
    texts = []
    for k in range(valid):
        text, tags = random_valid_model(rng, loops=loop_probability)
        texts.append(text)
        backend = "c" if ("loop" in tags or (c_every and k % c_every == 0)) else "numpy"
        try:
            outcome = run_valid(text, backend)
        except Exception as exc:  # noqa: BLE001 - every other outcome is the harness's finding
            outcome = "INTERNAL ERROR" if not isinstance(exc, Hang) else "HANG"
            failures.append((text, f"{type(exc).__name__}: {exc}"))
        outcomes[f"{outcome} [{backend}]" if outcome == "result" else outcome] += 1
    for k in range(mutated):
        text = mutate(rng, texts[k % len(texts)] if texts else randmodel.random_model(rng, 2)[0])
        try:
            outcome = run_mutated(text)
        except Exception as exc:  # noqa: BLE001
            outcome = "INTERNAL ERROR" if not isinstance(exc, Hang) else "HANG"
            failures.append((text, f"{type(exc).__name__}: {exc}"))
        outcomes[outcome] += 1
    return outcomes, failures


def table(outcomes: Counter) -> str:
    total = sum(outcomes.values())
    width = max((len(k) for k in outcomes), default=10)
    lines = [f"fuzz: {total} models"] + [f"  {k:<{width}}  {v:6d}" for k, v in outcomes.most_common()]
    return "\n".join(lines)
