"""The cold functions of a tree built on demand (runtime/backends.py ColdLibrary, ColdFunction; runtime/build.py
build_cold; mbs/pipeline.py cold_apart): a fresh compile leaves the mass matrix and the forces out, the first call
of one builds them from the whole file, and their values are those of the build that compiled them with the rest,
to the bit."""

from __future__ import annotations

import threading
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import mbs
from mbs import pipeline
from mbs import system as system_module
from mbs.runtime import build
from mbs.runtime.backends import ColdFunction, ColdLibrary
from mbs.runtime.errors import UsageError
from mbs.runtime.workspace import Workspace

pytestmark = pytest.mark.skipif(not build.have_c_compiler(), reason="needs a C compiler")

MODELS = Path(__file__).parent.parent / "compiler" / "models"
TREE, LOOPS = MODELS / "spatial_arm.mbs", MODELS / "four_bar.mbs"


def _states(compiled, n: int = 4) -> list[np.ndarray]:
    rng = np.random.default_rng(7)
    return [np.asarray(compiled.x0) + 0.3 * rng.standard_normal(compiled.nx) for _ in range(n)]


def _values(compiled, states) -> dict[str, list[np.ndarray]]:
    data = Workspace(compiled)
    return {name: [data.function(name)(0.0, x) for x in states] for name in ("rhs", "mass_matrix", "forces")}


def test_a_cold_function_called_after_a_simulate_gives_the_eager_builds_values(tmp_path, monkeypatch):
    """The fresh compile's file has no mass matrix nor forces, the run does not build them, and the first call does:
    the same values as the build that compiled them with the rest (and the same right-hand side), to the bit."""
    system = mbs.load(TREE, cache_dir=tmp_path)
    compiled = system.compile()
    gen = system.generate()
    assert gen.cold_apart and "int mbs_mass_matrix(" not in gen.c_source and "int mbs_rhs(" in gen.c_source
    assert {"mass_matrix", "forces"} <= set(compiled.functions)
    assert compiled.backend.functions["mass_matrix"] == (compiled.nv, compiled.nv)
    system.simulate(t_end=0.05)
    assert not compiled.backend.cold.loaded  # simulate never called them
    states = _states(compiled)
    lazy = _values(compiled, states)
    assert compiled.backend.cold.loaded
    monkeypatch.setattr(system_module, "COLD_APART", False)
    eager_system = mbs.load(TREE, cache_dir=tmp_path)
    eager = _values(eager_system.compile(), states)
    assert eager_system.compile().backend.cold is None
    for name in lazy:
        assert all(np.array_equal(a, b) for a, b in zip(lazy[name], eager[name])), name
    # the whole file is the eager one: what standalone libraries and FMUs are built from
    assert gen.whole_source == eager_system.generate().c_source


def test_the_file_apart_is_the_whole_file_without_its_cold_functions(tmp_path):
    """Every function of the file written apart is the whole file's, letter for letter (the same derivation and
    tape), and those it lacks are the mass matrix and the forces."""
    from mbs.runtime import translation_units as units
    model = mbs.load(TREE, cache_dir=tmp_path).model
    apart, whole = (pipeline.generate(model, None, cold_apart=c) for c in (True, False))
    mine, theirs = units.read_layout(apart.c_source), units.read_layout(whole.c_source)
    blocks = {b.name: b.text for b in theirs.functions}
    assert all(blocks[b.name] == b.text for b in mine.functions)
    assert {units.part_of(n) for n in set(blocks) - {b.name for b in mine.functions}} == {"mbs_mass_matrix",
                                                                                           "mbs_forces"}
    assert apart.whole_source == whole.c_source and not whole.cold_apart


def test_both_libraries_compile_without_warnings(tmp_path):
    """-Wall: the file apart defines no helper only the cold functions call; the cold library's units neither."""
    gen = mbs.load(TREE, cache_dir=tmp_path).generate()
    assert build.build(gen.c_source, cache_dir=tmp_path).warnings == ""
    cold = build.build_cold(gen.whole_source, cache_dir=tmp_path)
    assert cold.warnings == "" and cold.module_name.startswith("mbs_model_cold_")
    assert {name for name, _ in build.load(cold).FUNCTIONS} == {"mass_matrix", "forces"}


def test_a_model_with_loops_keeps_its_cold_functions():
    """The loop solver calls the mass matrix and the forces (or reads them off its loop terms): nothing apart.
    (The default cache: the four-bar's closed form, 4 to 30 s of sympy, is derived once for this test and
    test_closed_form_loops.)"""
    system = mbs.load(LOOPS)
    gen, compiled = system.generate(), system.compile()
    assert not gen.cold_apart and "int mbs_mass_matrix(" in gen.c_source and gen.whole_source == gen.c_source
    assert compiled.backend.cold is None and "mass_matrix" in compiled.backend.module.FUNCTIONS[1]
    system.simulate(t_end=0.05)
    m = Workspace(compiled).mass_matrix(0.0, compiled.x0)
    assert m.shape == (compiled.nv, compiled.nv) and np.all(np.isfinite(m))


def test_the_cold_library_is_cached_by_content(tmp_path, monkeypatch):
    """A second System on the same cache derives nothing and compiles nothing for its first mass matrix call."""
    first = mbs.load(TREE, cache_dir=tmp_path)
    x = first.compile().x0
    expected = Workspace(first.compile()).mass_matrix(0.0, x)
    derived, compiled = [], []
    real_generate, real_run = pipeline._generate, build._run
    monkeypatch.setattr(pipeline, "_generate", lambda *a, **k: derived.append(1) or real_generate(*a, **k))
    monkeypatch.setattr(build, "_run", lambda *a, **k: compiled.append(a[0]) or real_run(*a, **k))
    again = mbs.load(TREE, cache_dir=tmp_path).compile()
    assert np.array_equal(Workspace(again).mass_matrix(0.0, x), expected)
    assert again.backend.cold.loaded and derived == [] and compiled == []


def _fake_module(nwork: int = 4):
    return SimpleNamespace(NQ=1, NV=1, NX=2, NP=0, NWORK=nwork,
                           Function=lambda name, p, work: (lambda t, x: np.array([float(len(name))])))


def test_threads_asking_at_once_build_the_library_once():
    """The slot is filled once, under a lock, whoever asks first."""
    loads = []

    def slow():
        loads.append(1)
        time.sleep(0.05)
        return _fake_module()

    library = ColdLibrary(slow, {"NQ": 1, "NV": 1, "NX": 2, "NP": 0, "NWORK": 4})
    modules = []
    threads = [threading.Thread(target=lambda: modules.append(library.module())) for _ in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert loads == [1] and len(modules) == 8 and all(m is modules[0] for m in modules)


def test_a_library_of_other_sizes_is_refused():
    library = ColdLibrary(lambda: _fake_module(nwork=3), {"NQ": 1, "NV": 1, "NX": 2, "NP": 0, "NWORK": 4})
    with pytest.raises(UsageError, match="does not fit"):
        library.module()
    assert not library.loaded


def test_a_bound_cold_function_builds_nothing_until_called():
    """Binding (every workspace binds every function) and asking for dunder attributes (copy, functools) do not
    build; the first call does, once."""
    loads = []
    library = ColdLibrary(lambda: loads.append(1) or _fake_module(), {"NQ": 1, "NV": 1, "NX": 2, "NP": 0,
                                                                       "NWORK": 4})
    f = ColdFunction(library, "forces", np.zeros(0), np.zeros(4))
    assert not hasattr(f, "__wrapped__") and "not built yet" in repr(f) and loads == []
    assert f(0.0, np.zeros(2))[0] == len("forces") and f(0.0, np.zeros(2))[0] == len("forces") and loads == [1]
