"""Long generated functions in parts (compiler/ccode_parts.py): the plan carries exactly what later parts read, the
parted text compiles without warnings, and it computes what the whole function computes, to the bit."""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parents[2] / "bench"))
import treekit  # noqa: E402
from chain import chain  # noqa: E402

import mbs  # noqa: E402
from mbs.compiler import ccode_parts  # noqa: E402
from mbs.compiler.ccode import generate_c  # noqa: E402
from mbs.compiler.emit_common import Step  # noqa: E402
from mbs.compiler.equations import derive_equations  # noqa: E402
from mbs.compiler.kinematics import Kinematics  # noqa: E402

ROOT = Path(__file__).parents[2]


def _steps(*pairs):
    return [Step(name, text, "s", None) for name, text in pairs]


def test_a_short_function_stays_whole():
    steps = _steps(("a", "x0*2"), ("b", "a + 1"))
    assert ccode_parts.plan_parts(steps, [(0, "b")], part_chars=10, split_chars=100) is None


def test_the_plan_carries_what_later_parts_read_and_places_each_output_after_its_inputs(monkeypatch):
    monkeypatch.setattr(ccode_parts, "CUT_WINDOW", 0.0)  # cuts by length alone
    steps = _steps(("a", "x0*2.0"), ("b", "a + 1.0"), ("c", "sin(x1)"), ("d", "c*a"), ("e", "d + c"), ("f", "e*e"))
    results = [(0, "a"), (1, "f + b"), (2, "3.0"), (3, 1), (4, "c")]
    parts, slots, copies = ccode_parts.plan_parts(steps, results, part_chars=10, split_chars=1)
    assert [[s.name for s in p.steps] for p in parts] == [["a", "b"], ["c", "d"], ["e", "f"]]
    home = {s.name: k for k, p in enumerate(parts) for s in p.steps}
    # an output is written by the part that computes the last temporary it reads (a constant by the first)
    assert [dict(p.results) for p in parts] == [{0: "a", 2: "3.0"}, {4: "c"}, {1: "f + b"}]
    assert copies == ((3, 1),)
    # carried: exactly the names some later part reads; imported: exactly those a part reads from earlier ones
    assert set(slots) == {"a", "b", "c", "d"} and sorted(slots.values()) == list(range(4))
    for k, part in enumerate(parts):
        read = set().union(*(ccode_parts.names_in(t) for t in [s.text for s in part.steps]
                             + [v for _, v in part.results]))
        assert set(part.imports) == {n for n in read if home.get(n, k) < k}
        assert set(part.exports) == {s.name for s in part.steps if s.name in slots}


def test_a_cut_moves_to_where_the_fewest_temporaries_are_live():
    # ten steps of 10 characters, parts of 40: by length alone the cut falls before e (step 4); the window
    # (24..56 characters) allows c, d or e... before step 3, 4 or 5. a and b are read at the end; the chain c, d, e
    # ends in an output written at e: before f only a and b cross, before d or e also the chain's last link
    steps = _steps(("a", "x0*1.00000"), ("b", "x1*1.00000"), ("c", "x2*1.00000"), ("d", "c*1.000000"),
                   ("e", "d*1.000000"), ("f", "x3*1.00000"), ("g", "f*1.000000"), ("h", "g*1.000000"),
                   ("i", "h*1.000000"), ("j", "i + a + b"))
    parts, slots, _ = ccode_parts.plan_parts(steps, [(0, "j"), (1, "e")], part_chars=40, split_chars=1)
    assert [[s.name for s in p.steps] for p in parts] == [list("abcde"), list("fghij")]
    assert set(slots) == {"a", "b"}


def test_a_chain_in_parts_compiles_cleanly_and_gives_the_same_bits(tmp_path, monkeypatch):
    eqs = derive_equations(Kinematics(chain(6, symbolic=True)))
    whole = generate_c(eqs, eqs.parameters(), "chain6")
    monkeypatch.setattr(ccode_parts, "PART_CHARS", 600)
    monkeypatch.setattr(ccode_parts, "SPLIT_CHARS", 900)
    parted = generate_c(eqs, eqs.parameters(), "chain6")
    assert "int mbs_mass_matrix_part2(" in parted and "int mbs_rhs_part2(" in parted
    assert "int mbs_mass_matrix_part2(" not in whole
    for name in ("whole", "parted"):
        (tmp_path / name).mkdir()
    models = [treekit.CModel(text, tmp_path / name) for name, text in (("whole", whole), ("parted", parted))]
    assert models[1].warnings == ""
    rng = np.random.default_rng(7)
    for _ in range(5):
        x, p = rng.uniform(-1, 1, 12), np.r_[9.81, rng.uniform(0.5, 2, 12)]
        a, b = (m.evaluate(0.0, x, p) for m in models)
        for key in a:
            assert np.array_equal(a[key], b[key]), key
    # a NaN still gives status 2 from every part's function
    assert models[1].call("mbs_rhs", 0.0, [np.nan] + [0.0] * 11, [9.81] + [1.0] * 12, 12)[0] == 2


@pytest.fixture(scope="module")
def slider_crank_text():
    """The example slider-crank with outputs that read the accelerations and the loop's multipliers."""
    text = (ROOT / "library" / "examples" / "slider_crank.mbs").read_text()
    text = text.replace("    interact main_bearing {\n",
                        "    interact main_bearing {\n        sensor pin_load = reaction()\n")
    text = text.replace("    interact guide {\n", "    interact guide {\n        sensor slider_acc = acceleration()\n")
    return text + ("\nscene motion {\n    t_end = 0.2 s\n    output main_bearing.pin_load\n"
                   "    output guide.slider_acc\n    output guide.s\n}\n")


def test_a_closed_loop_model_in_parts_simulates_to_the_same_bits(slider_crank_text, tmp_path, monkeypatch):
    """The loop terms, the constraint functions and the outputs (which first solve for the accelerations and the
    multipliers, through pointers into work that each part declares for itself) in parts."""
    runs = {}
    for label, chars in (("whole", None), ("parted", 300)):
        if chars:
            monkeypatch.setattr(ccode_parts, "PART_CHARS", chars)
            monkeypatch.setattr(ccode_parts, "SPLIT_CHARS", chars)
        system = mbs.loads(slider_crank_text, path="slider_crank.mbs", cache_dir=tmp_path / label)
        code = system.generate("motion").c_source
        runs[label] = (code, system.simulate("motion"))
    code, parted = runs["parted"]
    assert "int mbs_loop_terms_part2(" in code and "int mbs_outputs_part2(" in code
    assert "int mbs_loop_terms_part2(" not in runs["whole"][0]
    whole = runs["whole"][1]
    assert parted.names == whole.names and len(parted.t) == len(whole.t) > 10
    assert np.array_equal(parted.data, whole.data)
