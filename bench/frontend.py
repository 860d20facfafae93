"""Front-end speed: parse and validate a generated model of N bodies (target: N = 1000 in under 2 s).

Prints the median time of the whole front end (text -> validated data model) and, as the baseline measured
in the same run, lark alone parsing the same text with its standard lexer and tree builder. The front end
builds its AST inside lark's parser with its own lexer (language/lexer.py), so it can beat the baseline
while also resolving names, converting units and validating.

    python bench/frontend.py [--bodies 1000] [--repeat 5]
"""

from __future__ import annotations

import argparse

from mbs.language.frontend import check_text
from mbs.language.parser import _lark
from timing import median_time  # bench/timing.py (the scripts run from bench/)

TARGET_SECONDS = 2.0


def generate(n: int) -> str:
    """A spatial chain of n bodies with alternating joint kinds, a frame, a spring and a sensor each."""
    lines = ["model chain {", "    param m = 1 kg", "    param l = 0.5 m", "    param k = 1000 N/m",
             "    param d = 2 N*s/m"]
    kinds = ["revolute(axis = x)", "revolute(axis = y)", "prismatic(axis = z)", "spherical"]
    for i in range(n):
        lines += [
            f"    rigid b{i} \"link {i}\" {{",
            "        body {",
            "            mass = m",
            "            com = (0, 0, -l / 2)",
            "            inertia = diag(m * l^2 / 12, m * l^2 / 12, 1e-3 kg*m^2)",
            "        }",
            "        frame tip at (0, 0, -l) rotate axis_angle(z, 5 deg)",
            "    }",
            f"    interact j{i} {{",
            f"        connect {'inertial' if i == 0 else f'b{i - 1}.tip'} -> b{i}",
            f"        joint {kinds[i % len(kinds)]}",
            "        force s = spring_damper(k = k, d = d, l0 = 0.1 m)",
            "        sensor p = position()",
            "    }",
        ]
    lines.append("}")
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bodies", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    text = generate(args.bodies)
    parser = _lark()
    parser.parse("model warm {}\n", start="start")
    lark_alone = median_time(lambda: parser.parse(text, start="start"), args.repeat)
    front_end = median_time(lambda: check_text(text, "chain.mbs"), args.repeat)
    print(f"model: {args.bodies} bodies, {len(text.splitlines())} lines, {len(text) / 1024:.0f} KiB")
    print(f"lark parse alone (baseline):  {lark_alone:8.3f} s  (median of {args.repeat})")
    print(f"parse + validate (mbs):       {front_end:8.3f} s  (median of {args.repeat})")
    print(f"ratio front end / lark alone: {front_end / lark_alone:8.2f}")
    verdict = "met" if front_end < TARGET_SECONDS else "NOT met"
    print(f"target: {args.bodies} bodies under {TARGET_SECONDS:.0f} s: {verdict}")


if __name__ == "__main__":
    main()
