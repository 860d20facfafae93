"""Named parameter sets (`--params benchmark`): the Iltis benchmark set reads against the vehicle, bad lines
are located errors, an unknown set names the known ones."""

import pytest

import mbs
from mbs import paramsets
from mbs.language.diagnostics import MbsError


@pytest.fixture(scope="module")
def vehicle():
    return mbs.load("library/iltis/vehicle.mbs")


def test_benchmark_set_makes_the_links_massless(vehicle):
    path = paramsets.locate("benchmark", paramsets.model_path(vehicle.model))
    values = paramsets.read(path, vehicle.model)
    assert len(values) == 12
    assert all(values[f"{c}.m_{part}"] == 0.0 for c in ("fl", "fr", "rl", "rr")
               for part in ("leaf", "carrier", "rod"))


def test_bad_lines_are_located(tmp_path, vehicle):
    bad = tmp_path / "bad.params"
    bad.write_text("# comment\nfl.m_leaf = 0 kg\nfl.bogus = 1\nfl.m_rod = 3 m  # a length\n")
    with pytest.raises(MbsError) as err:
        paramsets.read(bad, vehicle.model)
    rendered = [d.render() for d in err.value.diagnostics]
    assert len(rendered) == 2
    assert "bad.params:3:1: error: model 'vehicle' has no parameter 'fl.bogus'" in rendered[0]
    assert "bad.params:4:1: error: parameter fl.m_rod: expected mass" in rendered[1]


def test_unknown_set_lists_the_known_ones(vehicle):
    with pytest.raises(MbsError, match="sets beside the model: benchmark"):
        paramsets.locate("published", paramsets.model_path(vehicle.model))
