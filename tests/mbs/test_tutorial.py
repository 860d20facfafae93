"""docs/tutorial.md stays true: its Python runs as written (on library/examples/arm.mbs), and the controller it
designs holds the arm upright."""

import re
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def test_the_tutorial_python_runs_and_holds_the_arm_upright(tmp_path, monkeypatch):
    text = (ROOT / "docs" / "tutorial.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 3
    code = "\n".join(blocks).replace('"arm.mbs"', repr(str(ROOT / "library" / "examples" / "arm.mbs")))
    monkeypatch.chdir(tmp_path)
    scope: dict = {}
    exec(compile(code, "docs/tutorial.md", "exec"), scope)  # our own documentation, not user input
    lin, res = scope["lin"], scope["res"]
    assert np.all(np.linalg.eigvals(lin.A - lin.B @ scope["K"]).real < 0)
    assert np.max(np.linalg.eigvals(lin.A).real) > 1.0        # upright is unstable without the controller
    assert abs(res["shoulder.phi"][-1] - np.pi) < 1e-3 and abs(res["elbow.phi"][-1]) < 1e-3
    assert (tmp_path / "upright.png").stat().st_size > 1000
