"""The model library's code and constants moved onto huge pages at load (runtime/c/huge_text.c): where the kernel
offers transparent huge pages, the library's executable range is an anonymous mapping afterwards, and the model
computes the same bits with and without the move (MBS_HUGE_TEXT=0)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MODEL = ROOT / "library" / "examples" / "slider_crank.mbs"
THP = Path("/sys/kernel/mm/transparent_hugepage/enabled")

CHILD = """
import json, sys
import numpy as np
import mbs
res = mbs.load(sys.argv[1]).simulate(t_end=0.5, sample=0.01)
maps = [line.split() for line in open('/proc/self/maps')]
executable = [m for m in maps if m[1] == 'r-xp']
library = [m for m in maps if 'mbs_model_' in m[-1]]
# the library's executable range: between its first file mapping and its last one
lo = min(int(m[0].split('-')[0], 16) for m in library)
hi = max(int(m[0].split('-')[1], 16) for m in library)
mine = [m for m in executable if lo <= int(m[0].split('-')[0], 16) < hi]
print(json.dumps({"data": res.data.tobytes().hex(), "anonymous": all(len(m) == 5 for m in mine) and bool(mine)}))
"""


def run(env_off: bool) -> dict:
    env = dict(os.environ)
    if env_off:
        env["MBS_HUGE_TEXT"] = "0"
    else:
        env.pop("MBS_HUGE_TEXT", None)
    out = subprocess.run([sys.executable, "-c", CHILD, str(MODEL)], capture_output=True, text=True, env=env,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(not sys.platform.startswith("linux") or not THP.exists(),
                    reason="Linux with transparent huge pages")
def test_the_code_moves_onto_huge_pages_and_computes_the_same_bits():
    on = "[always]" in THP.read_text() or "[madvise]" in THP.read_text()
    moved, kept = run(env_off=False), run(env_off=True)
    assert moved["data"] == kept["data"]
    assert kept["anonymous"] is False  # MBS_HUGE_TEXT=0: the file's own mapping
    assert moved["anonymous"] is on
