"""TIR files: dimensional entries converted from the file's [UNITS] to SI, the coefficients become a parameter
set that the model accepts, and a file in degrees is refused at its line."""

import pytest

import mbs
from mbs.cli import main
from mbs.language.diagnostics import MbsError
from mbs.paramsets import read
from mbs.tir import read_tir

TIR = "tests/mbs/fixtures/example.tir"
PROBE = "tests/library/models/mf_probe.mbs"


def test_units_are_converted_to_si():
    c = read_tir(TIR)
    assert c["FNOMIN"] == pytest.approx(4500.0)               # 4.5 kN
    assert c["UNLOADED_RADIUS"] == pytest.approx(0.330)       # 330 mm
    assert c["VERTICAL_STIFFNESS"] == pytest.approx(210000.0)  # 0.21 kN/mm
    assert c["VERTICAL_DAMPING"] == pytest.approx(500.0)      # 0.0005 kN s/mm
    assert c["PKY1"] == -18.0                                  # coefficients stay as they are


def test_command_writes_a_parameter_set_the_model_accepts(tmp_path, capsys):
    out = tmp_path / "tyres.params"
    assert main(["tir", TIR, PROBE, "--instance", "tyre", "-o", str(out)]) == 0
    assert "not used by the model: FILE_VERSION, QSX1, WIDTH" in capsys.readouterr().out
    values = read(out, mbs.load(PROBE).model)
    assert values["tyre.R0"] == pytest.approx(0.33) and values["tyre.k"] == pytest.approx(210000.0)
    assert values["tyre.PCX1"] == 1.6


def test_degrees_are_refused_at_their_line(tmp_path):
    bad = tmp_path / "deg.tir"
    bad.write_text(open(TIR).read().replace("ANGLE                    ='radian'", "ANGLE = 'degree'"))
    with pytest.raises(MbsError) as err:
        read_tir(bad)
    text = err.value.diagnostics[0].render()
    assert "deg.tir:10:1: error: [UNITS] ANGLE = 'degree' is not supported" in text
