"""The model cache (mbs/model_cache.py): a second load of an unchanged file parses and validates nothing; a change
of the file, of any file it imports, or a new file where an import looked first reads the model again; a model
with errors is reported, located, with a cache present; a damaged or foreign entry is never read."""

from __future__ import annotations

import logging
import subprocess
import sys

import pytest

import mbs
from mbs import model_cache
from mbs.cli import main
from mbs.language import expr as X
from mbs.language import frontend
from mbs.runtime import cache as store

LAWS = """\
param k = {k} N/m "spring rate"
func spring(x) = -k * x
"""

MODEL = """\
import laws as laws
import forces.laws as library_laws

model slider {{
    param m = 2 kg
    rigid block {{
        body {{
            mass = m
            com = (0, 0, 0) m
            inertia = diag(0.1, 0.1, 0.1) kg*m^2
        }}
        frame base at (0, 0, 0) m
    }}
    interact rail {{
        connect inertial.origin -> block.base
        joint prismatic(axis = x) {{
            init s = 0.1 m
        }}
        force spring = joint(s = laws.spring(s))
        force damper = joint(s = -library_laws.linear_damper(der(s), {d} N*s/m))
    }}
    output position = rail.s
}}

scene slow {{
    param m = 4 kg
    t_end = 1 s
}}
"""


@pytest.fixture
def files(tmp_path, monkeypatch):
    """The model and its imported laws in a folder of their own (the working directory), and a fresh cache."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "laws.mbs").write_text(LAWS.format(k=100))
    (tmp_path / "slider.mbs").write_text(MODEL.format(d=3))
    return tmp_path, tmp_path / "cache"


@pytest.fixture
def reads(monkeypatch):
    """How often the front end reads a file (check_sources: parse and validate)."""
    calls = []
    real = frontend.check_sources

    def counted(path):
        calls.append(path)
        return real(path)

    monkeypatch.setattr(frontend, "check_sources", counted)
    return calls


def _entries(cache):
    return sorted(cache.glob(f"{store.CHECKED_PREFIX}*.json"))


def _spring_rate(model) -> float:
    return model.parameter_map["laws.k"].value


def test_a_second_load_reads_nothing_and_gives_the_same_model(files, reads, caplog):
    folder, cache = files
    first = model_cache.load("slider.mbs", cache_dir=cache)
    with caplog.at_level(logging.INFO, logger="mbs.cache"):
        second = model_cache.load("slider.mbs", cache_dir=cache)
    assert len(reads) == 1 and len(_entries(cache)) == 1
    assert "cache hit" in caplog.text
    assert second == first and repr(second) == repr(first)
    assert second.content_digest == first.content_digest
    # what later stages tell apart by identity stays the language's own constant (pipeline.fixed_state_names)
    assert [c.init_speed is X.ZERO for c in second.coordinates] == [c.init_speed is X.ZERO for c in first.coordinates]
    assert [c.init is X.ZERO for c in second.coordinates] == [False]  # `init s = 0.1 m` is written
    assert second.span.source.path == "slider.mbs"


def test_the_cached_model_simulates_as_the_fresh_one(files):
    folder, cache = files
    fresh = mbs.load("slider.mbs", cache_dir=cache).simulate("slow", sample=0.1)
    cached = mbs.load("slider.mbs", cache_dir=cache).simulate("slow", sample=0.1)
    assert (cached["position"] == fresh["position"]).all()


@pytest.mark.parametrize("edit", ["model", "import", "library import shadowed"])
def test_any_change_of_what_was_read_reads_the_model_again(files, reads, edit):
    folder, cache = files
    before = model_cache.load("slider.mbs", cache_dir=cache)
    if edit == "model":
        (folder / "slider.mbs").write_text(MODEL.format(d=5))
    elif edit == "import":
        (folder / "laws.mbs").write_text(LAWS.format(k=250))
    else:  # a file where `import forces.laws` looks before the library: it is imported now
        (folder / "forces").mkdir()
        (folder / "forces" / "laws.mbs").write_text('func linear_damper(v, d) = 2 * d * v "twice"\n')
    after = model_cache.load("slider.mbs", cache_dir=cache)
    assert len(reads) == 2
    assert after.content_digest != before.content_digest
    if edit == "import":
        assert (_spring_rate(before), _spring_rate(after)) == (100, 250)
    assert after == frontend.load("slider.mbs")
    reads.clear()
    model_cache.load("slider.mbs", cache_dir=cache)  # the new content is cached in turn
    assert reads == []


def test_the_code_that_reads_is_part_of_the_key(files, reads, monkeypatch):
    folder, cache = files
    model_cache.load("slider.mbs", cache_dir=cache)
    monkeypatch.setattr(model_cache, "FORMAT", model_cache.FORMAT + 1)
    model_cache.load("slider.mbs", cache_dir=cache)
    assert len(reads) == 2


@pytest.mark.parametrize("where", ["slider.mbs", "laws.mbs"])
def test_errors_are_located_with_a_cache_present(files, capsys, where):
    folder, cache = files
    model_cache.load("slider.mbs", cache_dir=cache)
    if where == "laws.mbs":
        (folder / "laws.mbs").write_text(LAWS.format(k=100).replace("-k * x", "-k * y"))
        expected = "laws.mbs:2:23: error:"
    else:
        (folder / "slider.mbs").write_text(MODEL.format(d=3).replace("mass = m", "mass = q"))
        expected = "slider.mbs:8:20: error:"
    with pytest.raises(mbs.MbsError) as err:
        model_cache.load("slider.mbs", cache_dir=cache)
    assert expected in str(err.value) and "^" in str(err.value)
    assert len(_entries(cache)) == 1  # a file with errors is not kept


def test_the_command_line_reports_errors_located_after_a_cached_run(files, capsys, monkeypatch):
    folder, cache = files
    monkeypatch.setenv("MBS_CACHE_DIR", str(cache))
    assert main(["-q", "simulate", "slider.mbs", "--scene", "slow", "--t-end", "0.1"]) == 0
    assert len(_entries(cache)) == 1
    capsys.readouterr()
    (folder / "laws.mbs").write_text(LAWS.format(k=100).replace("-k * x", "-k * y"))
    assert main(["-q", "simulate", "slider.mbs", "--scene", "slow"]) == 1
    err = capsys.readouterr().err
    assert "laws.mbs:2:23: error:" in err and "Traceback" not in err
    assert len(_entries(cache)) == 1  # a file with errors is not kept


def test_a_damaged_or_foreign_entry_is_read_again(files, reads, caplog):
    folder, cache = files
    fresh = frontend.load("slider.mbs")
    reads.clear()
    model_cache.load("slider.mbs", cache_dir=cache)
    (entry,) = _entries(cache)
    entry.write_bytes(entry.read_bytes()[:-20])
    with caplog.at_level(logging.WARNING, logger="mbs.cache"):
        model = model_cache.load("slider.mbs", cache_dir=cache)
    assert "not used" in caplog.text and len(reads) == 2
    assert model == fresh
    (entry,) = _entries(cache)  # written anew, intact
    assert store.read_derived(entry)[0] is not None
    entry.chmod(0o666)
    model_cache.load("slider.mbs", cache_dir=cache)
    assert len(reads) == 3


def test_the_cache_command_lists_and_verifies_the_entry(files, capsys):
    folder, cache = files
    model_cache.load("slider.mbs", cache_dir=cache)
    assert main(["cache", "--dir", str(cache), "list"]) == 0
    assert "slider (slider.mbs, validated)" in capsys.readouterr().out
    assert main(["cache", "--dir", str(cache), "verify"]) == 0


def test_a_warm_run_loads_neither_the_parser_nor_sympy(files, monkeypatch):
    """What a second `mbs simulate` of an unchanged model imports: no lark, sympy or scipy (python -X importtime
    shows what they cost)."""
    folder, cache = files
    monkeypatch.setenv("MBS_CACHE_DIR", str(cache))
    assert main(["-q", "simulate", "slider.mbs", "--scene", "slow"]) == 0
    probe = ("import sys\nfrom mbs.cli import main\n"
             "assert main(['-q', 'simulate', 'slider.mbs', '--scene', 'slow']) == 0\n"
             "print(sorted({m.split('.')[0] for m in sys.modules} & {'lark', 'sympy', 'scipy', 'matplotlib'}))\n")
    out = subprocess.run([sys.executable, "-c", probe], cwd=folder, capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "[]"
