"""Every command that runs or builds a model takes user hooks the same way (`--hook NAME=file.c`,
`--hook NAME=module.py:function`), each checked against the same law written as a plain expression
(library/examples/hook_friction.mbs, `plain = 1`); a hook declared but not supplied is an error before anything
is derived or built, in every command."""

from __future__ import annotations

import ctypes
import zipfile
from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.cli import main
from mbs.runtime.build import have_c_compiler

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = str(ROOT / "library" / "examples" / "hook_friction.mbs")
C_LAW = ROOT / "library" / "examples" / "hooks" / "friction_law.c"
PY_LAW = f"{ROOT / 'library' / 'examples' / 'hooks' / 'friction_law.py'}:friction_law"
C_HOOK = ["--hook", f"friction_law={C_LAW}"]
PY_HOOK = ["--hook", f"friction_law={PY_LAW}"]
needs_c = pytest.mark.skipif(not have_c_compiler(), reason="no C compiler")


def run(capsys, *argv) -> str:
    status = main([str(a) for a in argv])
    out = capsys.readouterr()
    assert status == 0, out.err
    return out.out


# ------------------------------------------------------------------------------------------ missing hooks
COMMANDS = {
    "simulate": ["simulate", EXAMPLE],
    "simulate --error-estimate": ["simulate", EXAMPLE, "--error-estimate"],
    "equilibrium": ["equilibrium", EXAMPLE],
    "linearize": ["linearize", EXAMPLE],
    "numerics": ["numerics", EXAMPLE],
    "accuracy": ["accuracy", EXAMPLE, "--integrators", "dopri5"],
    "modes": ["modes", EXAMPLE, "--speed-param", "vb"],
    "animate": ["animate", EXAMPLE, "-o", "page.html"],
    "compile": ["compile", EXAMPLE, "-o", "out"],
    "fmu": ["fmu", EXAMPLE, "-o", "model.fmu"],
    "sensitivity": ["sensitivity", EXAMPLE, "--param", "k"],
    "sweep": ["sweep", EXAMPLE, "--param", "k=50,100"],
    "optimize": ["optimize", EXAMPLE, "--param", "k=50:100", "--minimize", "peak(position)"],
    "eom --at": ["eom", EXAMPLE, "--at", "slide.s=0.01"],
}


@pytest.mark.parametrize("argv", COMMANDS.values(), ids=COMMANDS.keys())
def test_a_missing_hook_is_an_error_before_anything_is_derived_or_built(argv, capsys, monkeypatch, tmp_path):
    def never(*args, **kwargs):
        raise AssertionError("derived or built before the hooks were checked")
    monkeypatch.setattr("mbs.derivation_cache.generate", never)
    monkeypatch.setattr("mbs.eom.equations_of_motion", never)
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "hook_friction.mbs:23:5: error: hook 'friction_law' is declared but no implementation" in err
    assert "--hook friction_law=file.c" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []  # nothing written


# ------------------------------------------------------------------------------------------ analyses
@needs_c
def test_numerics_with_a_hook_reports_what_the_plain_law_gives(capsys):
    hooked = run(capsys, "numerics", EXAMPLE, *C_HOOK)
    assert hooked == run(capsys, "numerics", EXAMPLE, "--param", "plain=1", *C_HOOK)
    assert "eigenvalue" in hooked


@needs_c
def test_modes_with_a_hook_are_the_plain_laws(capsys):
    argv = ["modes", EXAMPLE, "--speed-param", "vb", "--speed", "0.1,0.3"]
    hooked = run(capsys, *argv, *PY_HOOK)
    assert hooked == run(capsys, *argv, "--param", "plain=1", *C_HOOK)
    assert "1.59" in hooked  # sqrt(k/m) / 2 pi = 1.5915 Hz, damped a little by the friction's slope


@needs_c
def test_accuracy_with_a_hook_measures_the_plain_laws_errors(capsys):
    argv = ["accuracy", EXAMPLE, "--integrators", "dopri5,rodasp", "--tolerances", "1e-5,1e-7", "--repeats", "1",
            "--t-end", "0.5"]

    def errors(text):
        rows = [line.split() for line in text.splitlines() if line.startswith(("dopri5 ", "rodasp "))]
        assert len(rows) == 4 and all(r[-1] == "finished" for r in rows)
        return np.array([[float(v) for v in r[2:5]] for r in rows])
    hooked = errors(run(capsys, *argv, *C_HOOK))
    plain = errors(run(capsys, *argv, "--param", "plain=1", *C_HOOK))
    # errors of 1e-6 .. 1e-3 against each one's reference at rtol 1e-9 (printed to 3 digits)
    np.testing.assert_allclose(hooked, plain, rtol=2e-2)


@needs_c
def test_eom_at_a_state_evaluates_a_python_hook(capsys):
    at = ["--at", "slide.s=0.01", "der(slide.s)=0.1"]
    hooked = run(capsys, "eom", EXAMPLE, *at, *PY_HOOK)
    assert hooked == run(capsys, "eom", EXAMPLE, *at, "--param", "plain=1", *PY_HOOK)
    assert main(["eom", EXAMPLE, *at, *C_HOOK]) == 2
    assert "a C file cannot be used there" in capsys.readouterr().err


@needs_c
def test_animate_with_a_hook_draws_the_plain_laws_motion(capsys, tmp_path):
    pages = tmp_path / "hooked.html", tmp_path / "plain.html"
    run(capsys, "animate", EXAMPLE, "-o", pages[0], "--t-end", "0.5", *PY_HOOK)
    run(capsys, "animate", EXAMPLE, "-o", pages[1], "--t-end", "0.5", "--param", "plain=1", *C_HOOK)
    assert pages[0].read_text() == pages[1].read_text()


# ------------------------------------------------------------------------------------------ builds
@needs_c
def test_compile_links_a_c_hook_and_documents_its_signature(capsys, tmp_path):
    run(capsys, "compile", EXAMPLE, "-o", tmp_path, *C_HOOK)
    header = (tmp_path / "hook_friction.h").read_text()
    assert "int friction_law(const double *arg, double *res);" in header
    assert "arg[0] = w [m/s], arg[1] = n [N], arg[2] = mu_s [1], arg[3] = mu_k [1]; res[0] = f [N]" in header
    assert "linked from friction_law.c" in header and "int NAME_derivative(const double *arg, double *jac)" in header
    lib = ctypes.CDLL(str(tmp_path / "libhook_friction.so"))
    lib.hook_friction_default_parameters.restype = ctypes.POINTER(ctypes.c_double)
    p = np.array(lib.hook_friction_default_parameters()[:7])
    double_p = ctypes.POINTER(ctypes.c_double)

    def rhs(x, plain):
        p[6] = plain
        xdot, work, x, params = np.zeros(2), np.zeros(8), np.array(x, dtype=float), p.copy()
        status = lib.hook_friction_rhs(ctypes.c_double(0.0), x.ctypes.data_as(double_p),
                                       params.ctypes.data_as(double_p), xdot.ctypes.data_as(double_p),
                                       work.ctypes.data_as(double_p))
        assert status == 0
        return xdot
    for x in ([0.01, 0.1], [0.02, 0.17], [-0.03, 0.5]):
        np.testing.assert_allclose(rhs(x, 0.0), rhs(x, 1.0), rtol=1e-13, atol=0)


def test_compile_refuses_a_python_hook(capsys, tmp_path):
    assert main(["compile", EXAMPLE, "-o", str(tmp_path), *PY_HOOK]) == 2
    assert "a Python implementation cannot go there" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


@needs_c
def test_fmu_compiles_a_c_hook_ships_its_source_and_runs_the_plain_laws_motion(capsys, tmp_path):
    fmpy = pytest.importorskip("fmpy")
    from fmpy.validation import validate_fmu
    fmu = tmp_path / "belt.fmu"
    run(capsys, "fmu", EXAMPLE, "-o", fmu, *C_HOOK)
    assert validate_fmu(str(fmu)) == []
    with zipfile.ZipFile(fmu) as z:
        assert z.read("sources/friction_law.c").decode() == C_LAW.read_text()
        assert '#include "friction_law.c"' in z.read("sources/model.c").decode()
        assert {"sources/mbs_fmu.c", "sources/fmu_defaults.h", "sources/ode.c"} <= set(z.namelist())
    md = fmpy.read_model_description(str(fmu))
    assert [s.sourceFiles for s in md.buildConfigurations[0].sourceFileSets] == [["mbs_fmu.c"]]
    rebuilt = rebuild_from_sources(fmu, tmp_path)
    res = mbs.load(EXAMPLE).simulate("cycles", params={"plain": 1}, rtol=1e-11, atol=1e-12,
                                     hooks={"friction_law": str(C_LAW)})
    for path, kind in ((fmu, "ModelExchange"), (fmu, "CoSimulation"), (rebuilt, "CoSimulation")):
        out = fmpy.simulate_fmu(str(path), fmi_type=kind, stop_time=res.t[-1], output_interval=0.01,
                                relative_tolerance=1e-10, output=["position", "friction_force"])
        assert len(out) == len(res)
        for name in ("position", "friction_force"):  # as tests/mbs/test_fmu.py: 1e-5 of 1 + peak
            assert np.max(np.abs(out[name] - res[name])) / (1 + np.max(np.abs(res[name]))) < 1e-5, kind


def rebuild_from_sources(fmu: Path, tmp_path: Path) -> Path:
    """A copy of the FMU whose binary is compiled anew from its sources/ alone (they are complete)."""
    import subprocess

    from mbs.runtime.build import compiler_command
    folder = tmp_path / "rebuild"
    with zipfile.ZipFile(fmu) as z:
        names = z.namelist()
        z.extractall(folder, [n for n in names if n.startswith("sources/")])
        binary = next(n for n in names if n.startswith("binaries/"))
        copy = tmp_path / "rebuilt.fmu"
        library = folder / "model.so"
        subprocess.run([*compiler_command(), "-shared", "-fPIC", "-O2", "-std=c99", str(folder / "sources" / "mbs_fmu.c"),
                        "-o", str(library), "-lm"], check=True, capture_output=True)
        with zipfile.ZipFile(copy, "w") as out:
            for name in names:
                out.writestr(name, library.read_bytes() if name == binary else z.read(name))
    return copy


def test_fmu_refuses_a_python_hook(capsys, tmp_path):
    assert main(["fmu", EXAMPLE, "-o", str(tmp_path / "m.fmu"), *PY_HOOK]) == 2
    assert "an FMU runs without Python" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
