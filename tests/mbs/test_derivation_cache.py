"""The derivation cache (mbs/derivation_cache.py): a second run of the same content derives nothing, any change of
what the derivation reads derives again, and a damaged or foreign entry is never read. A scene asking for other
outputs derives only those on the cached equations (the same text a whole derivation gives), and its build compiles
only the outputs' unit (runtime/build.py keeps the objects of split builds by content)."""

from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs import derivation_cache, pipeline
from mbs.runtime import build
from mbs.runtime import cache as store
from mbs.runtime import translation_units as units

CRANK = Path(__file__).resolve().parent / "fixtures" / "crank_outputs.mbs"
LIBRARY = Path(__file__).resolve().parents[2] / "library"

LAWS = """\
param k = {k} N/m "spring rate"
func spring(x) = -k * x
"""

MODEL = """\
import laws as laws

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
    }}
    output position = rail.s
}}

scene slow {{
    param m = 4 kg
    t_end = 1 s
    sample = 0.1 s
}}

scene fast {{
    param m = 1 kg
    t_end = 1 s
    sample = 0.1 s
}}

scene watched {{
    t_end = 1 s
    sample = 0.1 s
    output speed = der(rail.s)
}}
"""


@pytest.fixture
def project(tmp_path):
    """A model file importing a module of force laws, and a fresh cache folder."""
    (tmp_path / "laws.mbs").write_text(LAWS.format(k=100), encoding="utf-8")
    (tmp_path / "slider.mbs").write_text(MODEL.format(), encoding="utf-8")
    cache = tmp_path / "cache"
    return tmp_path, cache


@pytest.fixture
def derivations(monkeypatch):
    """Counts the derivations that run (pipeline.generate calls)."""
    calls = []
    real = pipeline.generate

    def counting(*args, **kwargs):
        calls.append(args[1].name if len(args) > 1 and args[1] is not None else None)
        return real(*args, **kwargs)

    monkeypatch.setattr(pipeline, "generate", counting)
    return calls


@pytest.fixture
def outputs_derived(monkeypatch):
    """Counts the derivations of outputs alone on cached equations (pipeline.generate_outputs calls)."""
    calls = []
    real = pipeline.generate_outputs

    def counting(model, scene, *args, **kwargs):
        calls.append(scene.name if scene is not None else None)
        return real(model, scene, *args, **kwargs)

    monkeypatch.setattr(pipeline, "generate_outputs", counting)
    return calls


def _generate(folder, cache, scene="slow"):
    system = mbs.load(folder / "slider.mbs", cache_dir=cache)
    return system, system.generate(scene)


def test_same_content_is_a_hit_and_gives_the_same_code(project, derivations):
    folder, cache = project
    _, first = _generate(folder, cache)
    _, again = _generate(folder, cache)
    assert derivations == ["slow"]
    assert again.c_source == first.c_source and again.numpy_source == first.numpy_source
    assert (again.q_names, again.v_names, again.p_names, again.y_names, again.layout, again.events) == \
           (first.q_names, first.v_names, first.p_names, first.y_names, first.layout, first.events)


def test_scenes_differing_in_parameters_share_one_derivation(project, derivations, outputs_derived, caplog):
    folder, cache = project
    system = mbs.load(folder / "slider.mbs", cache_dir=cache)
    slow, fast = system.generate("slow"), system.generate("fast")
    assert derivations == ["slow"] and fast.c_source == slow.c_source
    with caplog.at_level(logging.INFO, logger="mbs.cache"):
        watched = system.generate("watched")  # another output: only the outputs are derived, on the equations
    assert derivations == ["slow"] and outputs_derived == ["watched"]
    assert "the equations from the cache" in caplog.text
    assert watched.c_source[:watched.outputs_at] == slow.c_source[:slow.outputs_at]
    assert watched.y_names == ("speed",) and slow.y_names == ("position",)
    mbs.load(folder / "slider.mbs", cache_dir=cache).generate("watched")  # now both parts are kept
    assert derivations == ["slow"] and outputs_derived == ["watched"]


def test_an_edited_default_in_an_imported_file_derives_again(project, derivations):
    folder, cache = project
    _generate(folder, cache)
    (folder / "laws.mbs").write_text(LAWS.format(k=250), encoding="utf-8")
    _generate(folder, cache)
    assert derivations == ["slow", "slow"]
    (folder / "laws.mbs").write_text(LAWS.format(k=100), encoding="utf-8")  # the first content again: a hit
    _generate(folder, cache)
    assert derivations == ["slow", "slow"]


def test_a_run_from_the_cache_matches_a_derived_run(project):
    folder, cache = project
    derived = mbs.load(folder / "slider.mbs", cache_dir=cache).simulate("slow")
    cached = mbs.load(folder / "slider.mbs", cache_dir=cache).simulate("slow")
    assert np.array_equal(derived["rail.s"], cached["rail.s"])
    # the harmonic oscillator the model is: x = x0 cos(sqrt(k/m) t), m = 4 kg in scene slow
    assert np.allclose(cached["rail.s"], 0.1 * np.cos(np.sqrt(100 / 4) * cached.t), atol=1e-5)


def test_the_symbolic_stages_are_derived_again_on_demand(project, derivations):
    folder, cache = project
    _, first = _generate(folder, cache)
    _, again = _generate(folder, cache)
    assert derivations == ["slow"]
    assert len(again.equations.mass_matrix) == len(first.equations.mass_matrix) == 1
    assert derivations == ["slow", "slow"]


def _entry(cache, kind="outputs"):
    """The cache's derivation entry of this kind ('equations', or 'outputs': the scene's)."""
    (path,) = [p for p in cache.glob(f"{store.DERIVED_PREFIX}*.json") if store.read_derived(p)[0]["kind"] == kind]
    return path


def test_a_damaged_entry_is_derived_again_with_a_note(project, derivations, caplog):
    folder, cache = project
    _, first = _generate(folder, cache)
    path = _entry(cache, "equations")
    head, body = path.read_text(encoding="utf-8").split("\n", 1)
    path.write_text(head + "\n" + body.replace("mbs_rhs", "mbs_xyz", 1), encoding="utf-8")
    with caplog.at_level(logging.WARNING, logger="mbs.cache"):
        _, again = _generate(folder, cache)
    assert derivations == ["slow", "slow"] and again.c_source == first.c_source
    assert "SHA-256 mismatch" in caplog.text and "deriving the equations again" in caplog.text
    assert store.read_derived(path)[1] is None  # rewritten whole


@pytest.mark.skipif(not hasattr(os, "getuid"), reason="POSIX file owners")
def test_an_entry_others_can_write_is_not_read(project, derivations, caplog):
    folder, cache = project
    _generate(folder, cache)
    path = _entry(cache, "equations")
    path.chmod(0o666)
    with caplog.at_level(logging.WARNING, logger="mbs.cache"):
        _generate(folder, cache)
    assert derivations == ["slow", "slow"] and "others can write it" in caplog.text


def test_the_payload_is_plain_json(project):
    folder, cache = project
    _generate(folder, cache)
    head, body = _entry(cache).read_text(encoding="utf-8").split("\n", 1)
    record, payload = json.loads(head), json.loads(body)
    assert record["model"] == "slider (slider.mbs, scene slow)" and len(body.encode()) == record["size"]
    assert payload["key"].startswith(_entry(cache).stem.removeprefix(store.DERIVED_PREFIX))
    head, body = _entry(cache, "equations").read_text(encoding="utf-8").split("\n", 1)
    assert json.loads(head)["model"] == "slider (slider.mbs, equations)" and "mbs_rhs" in json.loads(body)["c_source"]


def test_the_key_names_the_code_that_derives(project):
    folder, _ = project
    system = mbs.load(folder / "slider.mbs")
    options = dict(jacobian=False)
    key = derivation_cache.derivation_key(system.model, system.scene("slow"), options)
    assert key == derivation_cache.derivation_key(system.model, system.scene("fast"), options)
    assert key != derivation_cache.derivation_key(system.model, system.scene("slow"), dict(jacobian=True))
    assert key != derivation_cache.derivation_key(system.model, system.scene("watched"), options)


def _mbs(*args, cache):
    env = {**os.environ, "MBS_CACHE_DIR": str(cache)}
    return subprocess.run([sys.executable, "-m", "mbs", *args], capture_output=True, text=True, env=env)


def test_cache_commands_list_and_verify_derivations(project):
    folder, cache = project
    _generate(folder, cache)
    listed = _mbs("cache", "list", cache=cache)
    assert listed.returncode == 0 and "slider (slider.mbs, scene slow)  (derived equations)" in listed.stdout
    assert _mbs("cache", "verify", cache=cache).returncode == 0
    path = _entry(cache)
    path.write_bytes(path.read_bytes()[:-10])
    damaged = _mbs("cache", "verify", "--remove", cache=cache)
    assert damaged.returncode == 1 and "damaged: its size is" in damaged.stderr and not path.exists()


# ---------------------------------------------------------------------------------- outputs apart from equations
def test_outputs_on_cached_equations_are_the_text_of_a_whole_derivation(tmp_path, derivations, outputs_derived):
    """A closed loop whose outputs read the multipliers (reactions): derived whole, and derived on the equations
    of a scene with other outputs, the file is the same text."""
    system = mbs.load(CRANK, cache_dir=tmp_path)
    whole = pipeline.generate(system.model, system.scene("loads"))
    system.generate("positions")
    on_cached = system.generate("loads")
    assert derivations == ["loads", "positions"] and outputs_derived == ["loads"]
    assert on_cached.c_source == whole.c_source and on_cached.outputs_at == whole.outputs_at
    assert on_cached.y_names == whole.y_names and len(whole.y_names) == 12  # guide.s is a state
    assert on_cached.p_names == whole.p_names and on_cached.layout == whole.layout


def test_other_outputs_compile_only_their_unit_and_agree(tmp_path, monkeypatch, caplog):
    """Split builds (every model split, as the Iltis is): the scene with other outputs compiles outputs.c and
    links the rest from the cache; its results are those of a run derived and built from nothing."""
    monkeypatch.setattr(units, "SPLIT_MIN_CHARS", 0)
    monkeypatch.setattr(units, "UNIT_CHARS", 4_000)
    cache = tmp_path / "cache"
    first = mbs.load(CRANK, cache_dir=cache)
    positions = first.simulate("positions")
    with caplog.at_level(logging.INFO, logger="mbs.cache"):
        loads = mbs.load(CRANK, cache_dir=cache).simulate("loads")
    built = [r.getMessage() for r in caplog.records if r.getMessage().startswith("C build of slider_crank")]
    assert len(built) == 1 and "compiled outputs.c; objects of " in built[0], built
    reused = built[0].split("objects of ")[1].split(" from the cache")[0].split(", ")
    assert "glue.c" in reused and len([u for u in reused if u.startswith("model_")]) > 2
    fresh = mbs.load(CRANK, cache_dir=tmp_path / "fresh").simulate("loads")  # derived whole, built whole
    for name in loads.names[1:]:
        assert np.array_equal(loads[name], fresh[name]), name
    assert np.array_equal(positions["guide.s"], loads["guide.s"])
    # a frictionless guide transmits nothing along its free direction, only the rod's push across it
    assert np.abs(loads["guide.load.fz"]).max() > 1.0
    assert np.abs(loads["guide.load.fx"]).max() < 1e-9 * np.abs(loads["guide.load.fz"]).max()


def test_an_edited_model_derives_and_compiles_its_changed_units_again(tmp_path, monkeypatch, derivations,
                                                                      outputs_derived, caplog):
    monkeypatch.setattr(units, "SPLIT_MIN_CHARS", 0)
    monkeypatch.setattr(units, "UNIT_CHARS", 4_000)
    model = tmp_path / "crank.mbs"
    model.write_text(CRANK.read_text(encoding="utf-8"), encoding="utf-8")
    before = mbs.load(model, cache_dir=tmp_path / "cache").simulate("loads")
    model.write_text(CRANK.read_text(encoding="utf-8").replace("com = (L / 2, 0, 0)", "com = (0.6 * L, 0, 0)"),
                     encoding="utf-8")
    with caplog.at_level(logging.INFO, logger="mbs.cache"):
        after = mbs.load(model, cache_dir=tmp_path / "cache").simulate("positions")
    assert derivations == ["loads", "positions"] and outputs_derived == []  # a new model: nothing reused
    built = [r.getMessage() for r in caplog.records if r.getMessage().startswith("C build of slider_crank")]
    # the units whose functions changed are compiled again (an unchanged one, and the glue when model.h is the
    # same, may come from the cache)
    assert len(built) == 1 and "model_" in built[0].split("compiled ")[1].split(";")[0], built
    assert not np.array_equal(before["guide.s"], after["guide.s"])


def test_other_outputs_on_cached_equations_do_not_print_the_equations(tmp_path, monkeypatch):
    """A scene with other outputs than the one derived before lowers the model and its outputs and derives the
    equations of motion (the outputs share their temporaries), but does not print the equations' code again (a
    closed loop: its outputs read the loop solver's accelerations and multipliers at run time); its results are
    those of a run derived and built from nothing."""
    from mbs.compiler import ccode
    calls = []
    real = ccode.generate_c

    def counting(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(ccode, "generate_c", counting)
    cache = tmp_path / "cache"
    mbs.load(CRANK, cache_dir=cache).simulate("positions")
    assert len(calls) == 1
    loads = mbs.load(CRANK, cache_dir=cache).simulate("loads")
    assert len(calls) == 1  # the equations' code from the cache, the outputs' part printed alone
    fresh = mbs.load(CRANK, cache_dir=tmp_path / "fresh").simulate("loads")
    assert len(calls) == 2
    assert loads.names == fresh.names
    for name in loads.names:
        assert np.array_equal(loads[name], fresh[name]), name


def test_a_scene_s_text_does_not_depend_on_the_scene_the_cache_met_first(tmp_path):
    """The Iltis quarter car's bump_5 derived on top of settle's cached equations is the text bump_5 derived
    whole has, to the byte (its outputs' part was another, with other round-off, when the outputs were lowered
    on a tape without the equations of motion: mbs/pipeline.py generate_outputs)."""
    model = mbs.load(LIBRARY / "iltis" / "quarter_car.mbs", cache_dir=tmp_path / "a").model
    scenes = {s.name: s for s in model.scenes}
    derivation_cache.generate(model, scenes["settle"], cache_dir=tmp_path / "a")
    on_top = derivation_cache.generate(model, scenes["bump_5"], cache_dir=tmp_path / "a").c_source
    whole = derivation_cache.generate(model, scenes["bump_5"], cache_dir=tmp_path / "b").c_source
    assert on_top == whole
