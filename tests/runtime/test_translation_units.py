"""Split builds (runtime/translation_units.py): the generated file read as header, helpers and functions; every function in
exactly one unit, helpers only where called; the split library computes what the one-unit library computes."""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.runtime import build
from mbs.runtime import translation_units as units

ROOT = Path(__file__).resolve().parents[2]
SLIDER_CRANK = ROOT / "library" / "examples" / "slider_crank.mbs"
TABLES = ROOT / "library" / "examples" / "two_mass_quarter_car.mbs"


#: A slider whose spring and drive are tables, and an output that is another.
TABLE_MODEL = """
model tables {
    param k = 100 N/m
    rigid bob {
        body {
            mass = 1 kg
            inertia = diag(1, 1, 1) kg*m^2
        }
    }
    interact slide {
        connect inertial -> bob
        joint prismatic(axis = z) { init s = 0.3 m }
        force spring = joint(s = -k * s * lookup(s, [[-1 m, 0.5], [0 m, 1], [1 m, 1.5]], "smooth"))
        force drive = joint(s = lookup(der(s), [[-1 m/s, 2 N], [0 m/s, 0 N], [1 m/s, -3 N]], "smooth"))
    }
    output shape = lookup(slide.s, [[-1 m, 2], [0 m, 0], [1 m, 2.5]], "smooth")
}
"""


@pytest.fixture(scope="module")
def generated():
    """The whole generated C (the cold functions included) of a closed-loop model and of a tree with outputs."""
    return {"slider_crank": mbs.load(SLIDER_CRANK).generate().whole_source,
            "quarter_car": mbs.load(TABLES).generate().whole_source}


def test_the_generated_layout_is_read_back_whole(generated):
    for code in generated.values():
        layout = units.read_layout(code)
        assert layout is not None
        names = [b.name for b in layout.functions]
        assert {"mbs_rhs", "mbs_mass_matrix", "mbs_forces", "mbs_qdot", "mbs_state_name"} <= set(names)
        assert all(h.name in ("mbs_all_finite", "mbs_positive_definite", "mbs_sign", "mbs_lookup", "mbs_sin", "mbs_cos",
                              "mbs_circular", "mbs_sin_poly", "mbs_cos_poly")
                   or re.fullmatch(r"mbs_table_\d+", h.name) for h in layout.helpers)
        assert "#define MBS_NWORK" in layout.header and "mbs_rhs(" not in layout.header
        # nothing lost, nothing twice: every line of the file (but trailing blank ones) is in the header or in
        # exactly one block
        pieces = [layout.header, *(b.text for b in layout.helpers + layout.functions)]
        if layout.outputs is not None:  # the outputs' part, after its marker line
            pieces.append(units.OUTPUTS_MARKER + "\n" + layout.outputs)
        assert sum(p.count("\n") + 1 for p in pieces) == code.rstrip("\n").count("\n") + 1
        for block in layout.helpers + layout.functions:
            assert code.split("\n")[block.line - 1:block.line - 1 + block.text.count("\n") + 1] == \
                   block.text.split("\n")


def test_a_hand_written_text_is_built_as_one_unit():
    text = (ROOT / "tests" / "runtime" / "fixtures" / "pendulum.c").read_text()
    assert units.split_sources(text * 40, "pendulum.c") is None  # duplicate definitions: not the layout
    assert units.split_sources("int mbs_rhs(void);\n" * 10_000, "x.c") is None


def test_every_function_lands_in_one_unit_with_the_helpers_it_calls(generated, monkeypatch):
    monkeypatch.setattr(units, "SPLIT_MIN_CHARS", 0)
    monkeypatch.setattr(units, "UNIT_CHARS", 2_000)
    files = units.split_sources(generated["slider_crank"], "slider_crank.c")
    layout = units.read_layout(generated["slider_crank"])
    bodies = {name: text for name, text in files.items() if name.startswith(("model_", units.COLD_PREFIX))}
    assert len(bodies) > 2
    for block in layout.functions:
        assert sum(block.text in text for text in bodies.values()) == 1
        assert block.prototype in files["model.h"]
    for text in bodies.values():
        for helper in layout.helpers:
            defined = helper.text in text
            called = re.search(rf"\b{helper.name}\(", text.replace(helper.text, "")) is not None
            assert defined == called, helper.name


def test_the_functions_no_integrator_calls_go_to_cold_units(generated, monkeypatch):
    """An open tree's mass matrix and forces (its rhs is the articulated-body algorithm) are compiled apart, at
    build.COLD_UNIT_FLAGS; so are a closed-loop model's when its loop solver takes M, f, G and the bias from the
    one-pass mbs_loop_terms (they are then read off it, with the constraint acceleration); without that function
    the loop solver calls them at every rhs."""
    monkeypatch.setattr(units, "SPLIT_MIN_CHARS", 0)
    tree = units.split_sources(generated["quarter_car"], "quarter_car.c")
    cold = {name: text for name, text in tree.items() if name.startswith(units.COLD_PREFIX)}
    assert cold and all(re.search(r"^int mbs_(mass_matrix|forces)", text, re.M) for text in cold.values())
    assert not any(re.search(r"^int mbs_(mass_matrix|forces)\(", text, re.M)
                   for name, text in tree.items() if name.startswith("model_"))
    assert any("int mbs_rhs(" in text for name, text in tree.items() if name.startswith("model_"))
    assert "#define MBS_LOOP_TERMS" in generated["slider_crank"]
    loops = units.split_sources(generated["slider_crank"], "slider_crank.c")
    cold = "\n".join(text for name, text in loops.items() if name.startswith(units.COLD_PREFIX))
    hot = "\n".join(text for name, text in loops.items() if name.startswith("model_"))
    for name in ("mbs_mass_matrix", "mbs_forces", "mbs_constraint_acceleration"):  # read off mbs_loop_terms
        assert re.search(rf"^int {name}\(", cold, re.M) and not re.search(rf"^int {name}\(", hot, re.M), name
    assert cold.count("mbs_loop_terms(t, x, p, work, NULL)") == 3
    assert re.search(r"^int mbs_loop_terms\(", hot, re.M) and re.search(r"^int mbs_constraints\(", hot, re.M)
    header = units.read_layout(generated["slider_crank"]).header
    assert units.cold_functions(header.replace("#define MBS_LOOP_TERMS", "#define MBS_NO_LOOP_TERMS")) == set()
    assert units.part_of("mbs_forces_part12") == "mbs_forces" and units.part_of("mbs_forces") == "mbs_forces"
    model_flags = ("-fmodel",)
    assert build.unit_flags("cold_1.c", model_flags, ()) == (*model_flags, *build.COLD_UNIT_FLAGS)
    assert build.unit_flags("model_1.c", model_flags, ("-fout",)) == model_flags
    assert build.unit_flags(units.OUTPUTS_UNIT, model_flags, ("-fout",)) == (*model_flags, "-fout")
    assert build.unit_flags(units.GLUE_UNIT, model_flags, ("-fout",)) == ()


def test_the_cold_library_has_the_cold_functions_of_a_whole_tree_file_alone(generated):
    """cold_sources (runtime/build.py build_cold): the whole file's header with the cold functions' prototypes and
    units of those functions alone, each with the helpers it calls (a table's lookup for the forces); none for a
    model with loops (its loop solver calls them) nor for a file written without them."""
    whole = generated["quarter_car"]
    files = units.cold_sources(whole, "quarter_car.c")
    bodies = {name: text for name, text in files.items() if name != "model.h"}
    assert bodies and all(name.startswith(units.COLD_PREFIX) for name in bodies)
    defined = set()
    for text in bodies.values():
        defined |= set(re.findall(r"^int (mbs_\w+)\(", text, re.M))
    assert {units.part_of(name) for name in defined} == {"mbs_mass_matrix", "mbs_forces"}
    assert "#define MBS_NWORK" in files["model.h"] and "int mbs_rhs(" not in files["model.h"]
    assert "int mbs_mass_matrix(double t" in files["model.h"]
    for text in bodies.values():  # helpers only where called (-Wall)
        for helper in re.findall(r"^static \w+ (mbs_\w+)\(", text, re.M):
            assert len(re.findall(rf"\b{helper}\(", text)) >= 2, helper
    assert units.cold_sources(generated["slider_crank"], "slider_crank.c") is None
    apart = mbs.load(TABLES).generate().c_source
    assert f"#define {units.COLD_APART} " in apart and units.cold_sources(apart, "quarter_car.c") is None
    assert build.unit_flags(units.COLD_GLUE_UNIT, ("-fmodel",), ()) == ()


@pytest.mark.parametrize("path", [SLIDER_CRANK, TABLES], ids=lambda p: p.stem)
def test_a_split_build_computes_what_one_unit_computes(path, tmp_path, monkeypatch):
    """Both libraries built from the same text, without a compiler warning; rhs, outputs and the loop solver's
    results agree to the last bit at a few states. (One fresh cache for both: the split build links the runtime
    object the single one compiled, and compiles every unit of its own.)"""
    system = mbs.load(path)
    gen = system.generate()
    single = build.build(gen.c_source, filename=path.stem + ".c", cache_dir=tmp_path)
    monkeypatch.setattr(units, "SPLIT_MIN_CHARS", 0)
    monkeypatch.setattr(units, "UNIT_CHARS", 4_000)
    split = build.build(gen.c_source, filename=path.stem + ".c", cache_dir=tmp_path)
    assert not single.cached and build.RUNTIME_UNIT in single.compiled
    assert not split.cached and split.reused == (build.RUNTIME_UNIT,)
    assert split.key != single.key and split.warnings == "" and single.warnings == ""
    assert "/* ==== glue.c ==== */" in (split.path.parent / (split.module_name + ".c")).read_text()
    a, b = build.load(single), build.load(split)
    assert (a.NQ, a.NV, a.NWORK) == (b.NQ, b.NV, b.NWORK)
    compiled = system.compile()
    rng = np.random.default_rng(1)
    p = np.zeros(a.NP)  # the parameters, then the switch flags at 0
    p[:len(compiled.p_default)] = compiled.p_default
    names = [name for name, _ in a.FUNCTIONS]
    assert names == [name for name, _ in b.FUNCTIONS] and "rhs" in names
    for _ in range(3):
        x = np.asarray(compiled.x0) + 0.01 * rng.standard_normal(a.NX)
        for name in names:
            if name in ("inverse_dynamics",):
                continue
            fa = a.Function(name, p, np.zeros(a.NWORK))
            fb = b.Function(name, p, np.zeros(b.NWORK))
            try:
                ya = fa(0.1, x)
            except Exception as exc:  # the same status from both
                with pytest.raises(type(exc)):
                    fb(0.1, x)
                continue
            assert np.array_equal(ya, fb(0.1, x), equal_nan=True), name


def test_compiler_messages_name_the_line_of_the_generated_file(generated, tmp_path, monkeypatch):
    monkeypatch.setattr(units, "SPLIT_MIN_CHARS", 0)
    code = generated["quarter_car"]
    lines = code.split("\n")
    at = lines.index(next(line for line in lines if line.startswith("int mbs_qdot("))) + 2
    lines.insert(at, "    int unused_here;")
    result = build.build("\n".join(lines), filename="qc.c", cache_dir=tmp_path)
    assert f"qc.c:{at + 1}:" in result.warnings and "unused_here" in result.warnings


def test_prebuild_compiles_the_equations_units_before_the_outputs_are_known(generated, tmp_path, monkeypatch):
    """prebuild (started with the equations' part while the outputs are derived) leaves the objects that build
    then links; every unit but outputs.c is compiled once, for this build."""
    monkeypatch.setattr(units, "SPLIT_MIN_CHARS", 0)
    monkeypatch.setattr(units, "UNIT_CHARS", 4_000)
    gen = mbs.load(TABLES).generate()
    assert gen.outputs_at is not None and gen.y_names
    started = build.prebuild(gen.c_source[:gen.outputs_at - 1], cache_dir=tmp_path)
    files = build._build_files(gen.c_source, "model.c")
    assert started == len([n for n in files if n.endswith(".c")]) - 1  # all but outputs.c
    result = build.build(gen.c_source, cache_dir=tmp_path)
    assert sorted(result.compiled) == sorted(n for n in files if n.endswith(".c")) and result.reused == ()
    assert not build._PREBUILDS and result.warnings == ""
    fresh = build.build(gen.c_source, cache_dir=tmp_path / "fresh")
    assert fresh.module_name == result.module_name
    a = build.load(result)
    assert a.NY == len(gen.y_names) and dict(a.FUNCTIONS)["outputs"] == (len(gen.y_names),)


def test_prebuilds_serve_a_scene_without_outputs(tmp_path, monkeypatch):
    """A scene without outputs (the 40-link chain's) has no outputs' part, which prebuild cannot know: model.h is
    the same text either way (the outputs' declarations are the glue unit's), so build compiles no model unit again."""
    monkeypatch.setattr(units, "SPLIT_MIN_CHARS", 0)
    monkeypatch.setattr(units, "UNIT_CHARS", 4_000)
    without = "\n".join(line for line in TABLE_MODEL.splitlines() if "output shape" not in line)
    gen = mbs.loads(without).generate()
    assert not gen.y_names and units.OUTPUTS_MARKER not in gen.c_source
    assert build.prebuild(gen.c_source[:gen.outputs_at - 1], cache_dir=tmp_path) > 0
    for job in list(build._PREBUILDS.values()):
        job.result()
    compiled, run = [], build._run
    monkeypatch.setattr(build, "_run", lambda command, *a: compiled.append(command[-1]) or run(command, *a))
    result = build.build(gen.c_source, cache_dir=tmp_path)
    assert compiled and not [name for name in compiled if name.startswith("model_")]
    assert result.warnings == "" and "outputs" not in dict(build.load(result).FUNCTIONS)


@pytest.mark.skipif(not hasattr(os, "fork"), reason="fork")
def test_a_forked_child_does_not_wait_for_the_parents_prebuilds(tmp_path, monkeypatch):
    """A sweep's workers may be forked while a prebuild runs: the child compiles what is not cached itself."""
    monkeypatch.setattr(units, "SPLIT_MIN_CHARS", 0)
    monkeypatch.setattr(units, "UNIT_CHARS", 4_000)
    gen = mbs.load(TABLES).generate()
    assert build.prebuild(gen.c_source[:gen.outputs_at - 1], cache_dir=tmp_path / "parent") > 0
    pid = os.fork()
    if pid == 0:  # the child: a build into another cache, with the parent's jobs forgotten
        code = 0 if not build._PREBUILDS and build.build(gen.c_source, cache_dir=tmp_path / "child").path.exists() else 1
        os._exit(code)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0
    build.build(gen.c_source, cache_dir=tmp_path / "parent")  # the parent's own jobs are still waited for
    assert not build._PREBUILDS


def test_a_lookup_tables_arrays_go_only_to_the_units_that_call_it(generated, monkeypatch):
    """The static const arrays of a table travel with its helper (the Iltis's road tables were 270 kB of every
    unit's model.h): none in model.h, and in a unit exactly when the unit calls the table."""
    monkeypatch.setattr(units, "SPLIT_MIN_CHARS", 0)
    monkeypatch.setattr(units, "UNIT_CHARS", 1_000)
    code = mbs.loads(TABLE_MODEL).generate().whole_source  # (the forces, in cold units, call both tables)
    tables = re.findall(r"^static double (mbs_table_\d+)\(double x\)$", code, re.M)
    assert len(tables) == 3  # the force's two, the output's one
    files = units.split_sources(code, "tables.c")
    assert len([name for name in files if name.endswith(".c")]) >= 3
    for table in tables:
        assert f"{table}_x[" not in files["model.h"] and f"{table}_y[" not in files["model.h"]
        calling = {name for name, text in files.items()
                   if re.search(rf"(?<!static double ){table}\((?!double x\))", text)}
        holding = {name for name, text in files.items() if f"static const double {table}_x[" in text}
        assert calling and calling == holding, table
    layout = units.read_layout(code)
    helper = next(h for h in layout.helpers if h.name == tables[0])
    assert helper.text.startswith("/* Lookup table") and f"{tables[0]}_y[" in helper.text


@pytest.mark.parametrize("outputs", [True, False], ids=["outputs", "no outputs"])
def test_the_glue_unit_compiles_from_the_files_head_while_its_functions_are_printed(outputs, tmp_path, monkeypatch):
    """The glue unit of a split file with loops includes the file's head and fixed declarations alone
    (translation_units.GLUE_HEADER), known before a function is printed: prebuild_head compiles it then, under the
    key build() later gives it (the head read off the whole file is the text handed over early), so build takes its
    object from the cache: the glue unit is compiled once, whether the scene has outputs (which it declares) or
    not (what the split computes: the test above, whose slider-crank glue unit includes GLUE_HEADER too)."""
    monkeypatch.setattr(units, "SPLIT_MIN_CHARS", 0)
    monkeypatch.setattr(units, "UNIT_CHARS", 4_000)
    monkeypatch.setattr(build, "HEAD_MIN_ENTRIES", 0)
    text = SLIDER_CRANK.read_text()
    if outputs:
        text = text.rstrip().removesuffix("}") + "    output crank_angle = main_bearing.phi\n}\n"
    heads, compiled, events = [], [], []
    prebuild_head, prebuild, run = build.prebuild_head, build.prebuild, build._run
    monkeypatch.setattr(build, "prebuild_head", lambda head, entries, **options: heads.append(head) or events.append(
        "head") or prebuild_head(head, entries, **options))
    monkeypatch.setattr(build, "prebuild", lambda code, **options: events.append("equations") or prebuild(
        code, **options))
    monkeypatch.setattr(build, "_run", lambda command, *a: compiled.append(
        command[command.index("-c") + 1] if "-c" in command else "link") or run(command, *a))
    system = mbs.loads(text, cache_dir=tmp_path)
    model = system.compile()
    gen = system.generate()
    files = build._build_files(gen.c_source, "model.c")
    assert events == ["head", "equations"] and heads == [units.file_head(gen.c_source)]
    assert units.GLUE_HEADER in files and f'#include "{units.GLUE_HEADER}"' in files[units.GLUE_UNIT]
    assert compiled.count(units.GLUE_UNIT) == 1 and (units.OUTPUTS_UNIT in compiled) == outputs
    assert not build._PREBUILDS and model.ny == outputs


def test_a_file_with_a_function_the_glue_header_does_not_declare_keeps_model_h(generated, monkeypatch):
    """glue.h declares a fixed list of functions: a file that defines another one (which the glue might call), or
    whose head declares one of them otherwise, gets none, and its glue unit includes model.h as before."""
    monkeypatch.setattr(units, "SPLIT_MIN_CHARS", 0)
    code = generated["slider_crank"]
    head = units.file_head(code)
    assert head.startswith("/* Equations of motion") and "int mbs_qdot(" not in head
    assert units.glue_header(head, "s.c") is not None
    assert units.glue_header(head, "s.c", ("int mbs_custom(double t, const double *x)",)) is None
    assert units.glue_header(head + "\nint mbs_rhs(double t);", "s.c") is None
    assert units.GLUE_HEADER in build._build_files(code, "s.c")
    extra = code.replace("\nint mbs_qdot(", "\nint mbs_custom(int i)\n{\n    return i;\n}\nint mbs_qdot(", 1)
    files = build._build_files(extra, "s.c")
    assert "int mbs_custom(int i);" in files["model.h"]
    assert units.GLUE_HEADER not in files and '#include "model.h"' in files[units.GLUE_UNIT]


def test_a_file_with_loops_is_split_from_a_fraction_of_the_size_a_tree_needs(monkeypatch):
    """The loop solver is in the glue unit: a model with loops splits from LOOP_SPLIT_FRACTION of SPLIT_MIN_CHARS
    (the Iltis quarter car, 95 kB, in parts: bench/split_threshold.py), a tree from SPLIT_MIN_CHARS."""
    code = mbs.load(SLIDER_CRANK).generate(None).c_source
    assert units.has_loops(code)
    tree = code.replace("#define MBS_NC ", "#define MBS_NOT_NC ")
    assert units.split_min_chars(code) == units.LOOP_SPLIT_FRACTION * units.SPLIT_MIN_CHARS < units.SPLIT_MIN_CHARS
    assert units.split_min_chars(tree) == units.SPLIT_MIN_CHARS
    monkeypatch.setattr(units, "SPLIT_MIN_CHARS", len(code) / units.LOOP_SPLIT_FRACTION - 1)
    assert units.split_sources(code, "model.c") is not None
    monkeypatch.setattr(units, "LOOP_SPLIT_FRACTION", 1.0)
    assert units.split_sources(code, "model.c") is None


def test_gccs_model_unit_flags_reach_the_model_units_alone_and_keep_the_results(tmp_path, monkeypatch):
    """runtime/build.py GCC_MODEL_UNIT_FLAGS (GCC only): every model unit's and the outputs' unit's compile command
    carries them (the outputs' -Og after them), the glue's and the runtime unit's none; and the library computes
    what the one without them computes, to the bit (they skip or trim passes: nothing reassociates)."""
    cc = tuple(build.compiler_command())
    if not build.model_unit_flags(cc):
        pytest.skip("the compiler is not GCC")
    assert build.model_unit_flags(cc) == build.GCC_MODEL_UNIT_FLAGS
    assert not any("fast-math" in f or "associative" in f or "contract" in f for f in build.GCC_MODEL_UNIT_FLAGS)
    monkeypatch.setattr(units, "SPLIT_MIN_CHARS", 0)
    monkeypatch.setattr(units, "UNIT_CHARS", 4_000)
    commands = []
    run = build._run
    monkeypatch.setattr(build, "_run", lambda command, cwd, filename: commands.append(command) or run(command, cwd,
                                                                                                       filename))
    system = mbs.load(TABLES)
    code = system.generate().c_source
    tuned = build.build(code, filename="quarter_car.c", cache_dir=tmp_path)
    compiles = {command[command.index("-c") + 1]: command for command in commands if "-c" in command}
    model = [name for name in compiles if name.startswith("model_")]
    assert model and units.OUTPUTS_UNIT in compiles and units.GLUE_UNIT in compiles and build.RUNTIME_UNIT in compiles
    flags = build.GCC_MODEL_UNIT_FLAGS
    for name in model:
        at = compiles[name].index(flags[0])
        assert compiles[name][at:at + len(flags)] == flags, name
    outputs = compiles[units.OUTPUTS_UNIT]
    at = outputs.index(flags[0])
    assert outputs[at:at + len(flags) + len(build.OUTPUTS_UNIT_FLAGS)] == (*flags, *build.OUTPUTS_UNIT_FLAGS)
    for name in (units.GLUE_UNIT, build.RUNTIME_UNIT):
        assert not set(flags) & set(compiles[name]), name
    plain = build.build(code, filename="quarter_car.c", cache_dir=tmp_path, model_flags=())
    assert plain.key != tuned.key and not plain.cached
    a, b = build.load(tuned), build.load(plain)
    compiled = system.compile()
    p = np.zeros(a.NP)
    p[:len(compiled.p_default)] = compiled.p_default
    rng = np.random.default_rng(5)
    for _ in range(4):
        x = np.asarray(compiled.x0) + 0.01 * rng.standard_normal(a.NX)
        for name in ("rhs", "outputs"):
            fa, fb = a.Function(name, p, np.zeros(a.NWORK)), b.Function(name, p, np.zeros(b.NWORK))
            assert np.array_equal(fa(0.1, x), fb(0.1, x)), name
