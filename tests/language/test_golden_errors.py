"""Golden tests: the exact text `mbs check` prints for every validation rule (tests/language/errors/).

Each NAME.mbs has NAME.expected, the complete stderr. To accept new texts after a deliberate change to a
message: MBS_REGOLD=1 pytest tests/language/test_golden_errors.py, then review the diff before committing.
"""

import os
from pathlib import Path

import pytest

from mbs.cli import main

ERRORS = Path(__file__).parent / "errors"
CASES = sorted(p.stem for p in ERRORS.glob("*.mbs"))


@pytest.mark.parametrize("name", CASES)
def test_error_text_is_exactly_the_golden_one(name, capsys):
    path = ERRORS / f"{name}.mbs"
    status = main(["check", str(path.relative_to(Path.cwd()))])
    err = capsys.readouterr().err
    expected_file = ERRORS / f"{name}.expected"
    if os.environ.get("MBS_REGOLD"):
        expected_file.write_text(err)
    assert status == 1
    assert err == expected_file.read_text()
    assert "Traceback" not in err


def test_every_rule_has_a_golden_case():
    """Guard against deleting cases: the rules listed here each need a fixture."""
    rules = {"syntax_several", "unknown_unit", "unit_mismatch_slot", "unit_mismatch_add", "duplicate_names",
             "unknown_references", "same_part", "mass_properties", "axes", "unreachable", "joint_members",
             "prescribed_state", "parameter_cycle", "component_errors", "acceleration_in_force", "scene_errors",
             "functions", "rotations", "rigid_without_body", "binary_file", "not_utf8", "truncated", "quaternion_speeds", "inertia_about",
             "bound_parameters"}
    assert rules <= set(CASES)
