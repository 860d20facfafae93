"""The derivation cache (mbs/derivation_cache.py): a second run of the same content derives nothing, any change of
what the derivation reads derives again, and a damaged or foreign entry is never read."""

from __future__ import annotations

import json
import logging
import os
import subprocess
import sys

import numpy as np
import pytest

import mbs
from mbs import derivation_cache, pipeline
from mbs.runtime import cache as store

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


def test_scenes_differing_in_parameters_share_one_derivation(project, derivations):
    folder, cache = project
    system = mbs.load(folder / "slider.mbs", cache_dir=cache)
    slow, fast = system.generate("slow"), system.generate("fast")
    assert derivations == ["slow"] and fast.c_source == slow.c_source
    system.generate("watched")  # another output: derived on its own
    assert derivations == ["slow", "watched"]


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


def _entry(cache):
    (path,) = cache.glob(f"{store.DERIVED_PREFIX}*.json")
    return path


def test_a_damaged_entry_is_derived_again_with_a_note(project, derivations, caplog):
    folder, cache = project
    _, first = _generate(folder, cache)
    path = _entry(cache)
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
    path = _entry(cache)
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
