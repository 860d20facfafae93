"""Building: cache hits and misses, concurrent builds, compiler errors, warning-free runtime C."""

from __future__ import annotations

import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from mbs.language.diagnostics import MbsError
from mbs.runtime import build, cache
from mbs.runtime.errors import BuildError

FIXTURES = Path(__file__).parent / "fixtures"

PENDULUM = FIXTURES / "pendulum.c"


def test_second_build_is_a_cache_hit(builds, cache_dir):
    first = builds["pendulum.c"]  # built fresh by the session fixture
    assert not first.cached and first.path.exists()
    inode, data = first.path.stat().st_ino, first.path.read_bytes()
    second = build.build_file(PENDULUM, cache_dir=cache_dir)
    assert second.cached and second.path == first.path and second.key == first.key
    # not rewritten (a new file would replace it: another inode); its mtime is its last use (runtime/cache_bound.py)
    assert second.path.stat().st_ino == inode and second.path.read_bytes() == data


def test_changed_source_misses_the_cache(builds, cache_dir):
    text = PENDULUM.read_text()
    assert build.build(text, filename="pendulum.c", cache_dir=cache_dir).cached  # same text, same key
    edited = build.build(text + "\n/* edited */\n", filename="pendulum.c", cache_dir=cache_dir)
    assert not edited.cached and edited.key != builds["pendulum.c"].key
    assert edited.module_name != builds["pendulum.c"].module_name
    assert build.build(text + "\n/* edited */\n", filename="pendulum.c", cache_dir=cache_dir).cached


def test_flags_and_compiler_enter_the_key():
    unit, cc = "int x;", tuple(build.compiler_command())
    keys = {build._hash(unit, "m.c", build.FLAGS, (), cc), build._hash(unit, "m.c", build.FLAGS + ("-DX",), (), cc),
            build._hash(unit + " ", "m.c", build.FLAGS, (), cc), build._hash(unit, "m.c", build.FLAGS, ("-DX",), cc),
            build._hash(unit, "n.c", build.FLAGS, (), cc)}
    assert len(keys) == 5


def test_cache_dir_from_environment(builds, tmp_path, monkeypatch):
    monkeypatch.setenv(build.CACHE_ENV, str(tmp_path / "env-cache"))
    assert build.default_cache_dir() == tmp_path / "env-cache"
    # seed the environment's cache with the session's module: the build is then a hit there
    (tmp_path / "env-cache").mkdir()
    shutil.copy(builds["pendulum.c"].path, tmp_path / "env-cache")
    shutil.copy(cache.record_path(builds["pendulum.c"].path), tmp_path / "env-cache")  # its build record
    result = build.build_file(PENDULUM)
    assert result.cached and result.path.parent == tmp_path / "env-cache"


def test_runtime_and_fixtures_compile_without_warnings(builds):
    assert set(builds) == {"order_problems.c", "pendulum.c", "pendulum_failing.c", "quarter_car.c"}
    for name, result in builds.items():
        assert not result.cached, name  # a fresh build, so the compiler's messages were seen
        assert result.warnings == "", result.warnings


def test_two_processes_building_at_once(tmp_path):
    script = textwrap.dedent(f"""
        import sys
        from pathlib import Path
        import numpy as np
        from mbs.runtime import build
        r = build.build_file(Path({str(PENDULUM)!r}), cache_dir={str(tmp_path)!r})
        m = build.load(r)
        f = m.Function("rhs", np.array([1.0, 1.0, 9.81]), np.zeros(m.NWORK))
        print(r.cached, f(0.0, [0.5, 0.0])[1])
    """)
    procs = [subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True) for _ in range(2)]
    outputs = [p.communicate(timeout=120) for p in procs]
    for p, (out, err) in zip(procs, outputs):
        assert p.returncode == 0, err
        assert out.split()[1] == repr(-9.81 * __import__("math").sin(0.5))
    modules = [p for p in tmp_path.iterdir() if p.name.endswith(".so")]
    assert len(modules) == 1
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".build-")]  # temp dirs cleaned up


def test_compiler_error_raises_build_error_with_the_message(tmp_path):
    bad = "#define MBS_NQ 1\nint mbs_rhs(double t) { return undefined_name; }\n"
    with pytest.raises(BuildError) as info:
        build.build(bad, filename="broken_model.c", cache_dir=tmp_path)
    err = info.value
    assert isinstance(err, MbsError)  # rendered by the CLI without a traceback
    assert "compiling broken_model.c failed" in str(err)
    assert "broken_model.c:2" in err.compiler_output and "undefined_name" in err.compiler_output
    assert str(err).startswith("error: compiling broken_model.c failed")
    assert not list(tmp_path.iterdir())  # no module, no leftover build directory


def test_missing_sizes_are_reported(cache_dir):
    # (the session's cache: the runtime object is there, so the failing build is one compiler call, not two)
    with pytest.raises(BuildError, match="MBS_NQ, MBS_NV, MBS_NX, MBS_NP and MBS_NWORK"):
        build.build("int x;\n", cache_dir=cache_dir)


def test_missing_compiler(tmp_path, monkeypatch):
    monkeypatch.setenv("CC", "/nonexistent/cc-for-test")
    with pytest.raises(BuildError, match="no usable C compiler"):
        build.build_file(PENDULUM, cache_dir=tmp_path)
    assert not build.have_c_compiler()


def test_load_twice_returns_the_same_module(cache_dir):
    result = build.build_file(PENDULUM, cache_dir=cache_dir)
    assert build.load(result) is build.load(result)
    assert result.module_name in sys.modules


def _objects(folder: Path) -> list[Path]:
    return sorted(folder.glob(cache.OBJECT_PREFIX + "*.o"))


def test_the_runtime_object_is_compiled_once_and_linked_into_every_model(tmp_path):
    """The bindings and the integrators (c/mbs_python.c) are one cached object: the first build compiles it, the
    next model only its own unit; both modules integrate."""
    first = build.build_file(PENDULUM, cache_dir=tmp_path)
    second = build.build_file(FIXTURES / "quarter_car.c", cache_dir=tmp_path)
    assert first.compiled == ("unit.c", build.RUNTIME_UNIT) and first.reused == ()
    assert second.compiled == ("unit.c",) and second.reused == (build.RUNTIME_UNIT,)
    (runtime,) = _objects(tmp_path)
    assert cache.problem(runtime) is None and build.runtime_object(cache_dir=tmp_path) == runtime
    assert "Python bindings" in cache.read_record(runtime)["model"]
    for result in (first, second):
        module = build.load(result)
        assert module.METHODS == ("dopri5", "rodasp", "rodas5p", "adams")
        p = np.ones(module.NP)  # unit masses, lengths, stiffnesses
        f = module.Function("rhs", p, np.zeros(module.NWORK))
        solver = module.Solver("dopri5", f, 0.0, np.zeros(module.NX), 0.1, 1e-8, 1e-10)
        while solver.status == module.STATUS_RUNNING:
            solver.step()
        assert solver.status == 101 and solver.t == 0.1


def test_a_damaged_runtime_object_is_compiled_again_never_linked(tmp_path):
    build.build_file(PENDULUM, cache_dir=tmp_path)
    (runtime,) = _objects(tmp_path)
    size = runtime.stat().st_size
    with open(runtime, "r+b") as f:
        f.truncate(size // 2)
    assert "size is" in cache.problem(runtime)
    again = build.build(PENDULUM.read_text() + "\n/* another model */\n", filename="pendulum.c", cache_dir=tmp_path)
    assert build.RUNTIME_UNIT in again.compiled and cache.problem(runtime) is None
    assert runtime.stat().st_size == size and build.load(again).NX == 2


def test_the_runtime_object_follows_its_c_files_and_the_flags_not_the_model(tmp_path, monkeypatch):
    """Its key: the files it is made of (an edit of one compiles it again), the flags, the compiler; a model's
    text, its header and the loop solver (compiled with the model) do not enter it."""
    cc = tuple(build.compiler_command())

    def key(files=None, flags=build.FLAGS):
        files = {**(files or {}), build.RUNTIME_UNIT: build._runtime_unit()}
        jobs = {name: path for name, _, path in build._unit_jobs(files, flags, (), cc, tmp_path)}
        return jobs[build.RUNTIME_UNIT]

    base = key()
    assert key({"model.h": "#define MBS_NX 2\n", "glue.c": "/* x */"}) == base
    assert key(flags=build.FLAGS + ("-DX",)) != base
    copy = tmp_path / "c"
    shutil.copytree(build.C_DIR, copy)
    monkeypatch.setattr(build, "C_DIR", copy)
    base = key()  # (the include folder is in the command)
    (copy / "loops.c").write_text((copy / "loops.c").read_text() + "\n/* edited */\n")
    assert key() == base
    (copy / "ode.c").write_text((copy / "ode.c").read_text() + "\n/* edited */\n")
    assert key() != base


def test_cpu_flags_follow_the_environment_and_enter_the_cache_key(monkeypatch):
    """$MBS_CPU_FLAGS replaces the detected instruction-set flags (empty: none); they are part of every unit's flags,
    so a library built with them has a key of its own (a machine without them never loads it)."""
    cc = tuple(build.compiler_command())
    monkeypatch.setenv(build.CPU_FLAGS_ENV, "")
    assert build.cpu_flags(cc) == () and build.base_flags(cc) == build.FLAGS + build.PLATFORM_FLAGS
    portable = build._hash("int x;", "m.c", build.base_flags(cc), (), cc)
    monkeypatch.setenv(build.CPU_FLAGS_ENV, "-mavx2 -mtune=native")
    assert build.cpu_flags(cc) == ("-mavx2", "-mtune=native")
    assert build.base_flags(cc)[-2:] == ("-mavx2", "-mtune=native")
    assert build._hash("int x;", "m.c", build.base_flags(cc), (), cc) != portable
    monkeypatch.delenv(build.CPU_FLAGS_ENV)
    detected = build.cpu_flags(cc)
    assert detected in ((), build.AVX2_FLAGS, build.AVX2_FLAGS + build.GCC_TUNE_FLAGS)
    if detected:
        assert "avx2" in build._cpu_features()


def test_the_cpu_flags_change_no_bit_of_a_loop_model(tmp_path, monkeypatch):
    """The slider-crank's rhs, outputs and projection the same to the bit with and without the detected flags (the
    flags add no fused multiply-add and no reassociation)."""
    import mbs
    cc = tuple(build.compiler_command())
    monkeypatch.delenv(build.CPU_FLAGS_ENV, raising=False)
    flags = build.cpu_flags(cc)
    if not flags:
        pytest.skip("this CPU and compiler get no instruction-set flags")
    system = mbs.load(Path(__file__).parents[2] / "library" / "examples" / "slider_crank.mbs", cache_dir=tmp_path)
    code = system.generate(None).c_source
    monkeypatch.setenv(build.CPU_FLAGS_ENV, "")
    plain = build.load(build.build(code, cache_dir=tmp_path))
    monkeypatch.setenv(build.CPU_FLAGS_ENV, " ".join(flags))
    flagged = build.load(build.build(code, cache_dir=tmp_path))
    assert plain.__name__ != flagged.__name__
    rng = np.random.default_rng(7)
    p = np.asarray(system.compile(None).p_default, dtype=float)
    for name in ("rhs", "loop_rhs", "project", "outputs"):
        if name not in dict(plain.FUNCTIONS):
            continue
        f0, f1 = (m.Function(name, p.copy(), np.zeros(m.NWORK)) for m in (plain, flagged))
        for _ in range(20):
            x = rng.uniform(-1.0, 1.0, plain.NX)
            a, b = np.asarray(f0(0.3, x)), np.asarray(f1(0.3, x))
            assert np.array_equal(a, b, equal_nan=True), name
