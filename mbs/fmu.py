"""FMI 2.0 export: a model (one scene's outputs and settings) as an FMU for Model Exchange and Co-Simulation.

    mbs fmu library/examples/pendulum.mbs --scene swing -o pendulum.fmu

The FMU's binary is the generated C compiled together with runtime/c/mbs_fmu.c, which implements the FMI
functions over the run time's entry points (mbs_rhs, mbs_outputs, mbs_project) and co-simulates with the run
time's DOPRI5 in C. modelDescription.xml lists the states and their derivatives, the parameters (tunable,
with units and descriptions) and the scene's outputs. The start state is the scene's: joint and scene inits,
closed loops assembled, the static equilibrium when the scene starts there (for the default parameters; an
importer that changes a parameter may set the states' start values too).

sources/ holds everything the binary was built from (mbs_fmu.c includes the rest): an importer on another
platform can rebuild it. User hooks go in as C only (`mbs fmu --hook NAME=file.c`): each file is compiled into
the binary and shipped in sources/ under its name; a Python hook is refused, since an FMU runs without Python.

Events: the model's switches (comparisons and kinks, on by default) and its events are event indicators
(numberOfEventIndicators).  Model Exchange importers locate their crossings and the FMU applies them in event mode
(`set`, `reinit`: valuesOfContinuousStatesChanged, `terminate`: terminateSimulation); Co-Simulation locates them
inside fmi2DoStep (a `terminate` ends the step with fmi2Discard and the fmi2Terminated status), both in
runtime/c/mbs_fmu.c, as `mbs simulate` applies them.  The branch flags are not listed as parameters.  A switched
friction element (its held forces are checked in Python after every event) is refused with a message
(event_table).
"""

from __future__ import annotations

import hashlib
import platform
import re
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

import mbs
from mbs.base.atomic import atomic_path
from mbs.language.diagnostics import Diagnostic, MbsError
from mbs.runtime.build import C_DIR, compiler_command

FLAGS = ["-O2", "-fPIC", "-shared", "-std=c99", "-Wall", "-fvisibility=hidden"]


def platform_folder() -> str:
    """binaries/<folder> of the FMI standard for this machine."""
    bits = "64" if sys.maxsize > 2 ** 32 else "32"
    system = {"linux": "linux", "darwin": "darwin", "win32": "win"}.get(sys.platform)
    if system is None:
        raise MbsError([Diagnostic("error", f"mbs fmu: no FMI platform name for {sys.platform}", None)])
    return system + bits


def identifier(name: str) -> str:
    """The modelIdentifier: the model name as a C identifier (it names the shared library)."""
    ident = re.sub(r"\W", "_", name)
    return ident if re.match(r"[A-Za-z_]", ident) else f"m_{ident}"


def start_state(system, scene: str | None, hooks=None) -> np.ndarray:
    """The state a run of the scene starts from (assembled loops, equilibrium when the scene says so); hooks:
    the implementations of the model's user hooks."""
    from mbs.runtime.equilibrium import static_equilibrium
    compiled, gen, values = system._scene_parameters(scene, None, hooks)
    data = system._workspace(compiled, gen, values)
    sc = system.scene(scene)
    if sc is not None and sc.start == "equilibrium":
        data.x = static_equilibrium(compiled, data, data.x).x
    return np.array(data.x), np.array(data.p)


def _number(x: float) -> str:
    return repr(float(x))


def model_description(system, scene: str | None, guid: str, x0, p0, hooks=None) -> str:
    """modelDescription.xml text (FMI 2.0, flat names: a state 'der(j.phi)' has the derivative "der(j.phi)'")."""
    from mbs.system import _settings
    compiled = system.compile(scene, hooks=hooks)
    model = system.model
    sc = system.scene(scene)
    settings = _settings(sc, None, None, None, None, None)
    units = dict(compiled.units)
    described = {p.name: p.description for p in model.parameters}
    described.update({o.name: o.description for o in model.outputs})
    if sc is not None:
        described.update({o.name: o.description for o in sc.outputs if o.description})
    ident = identifier(model.name)
    variables, used_units = [], set()

    def variable(name, vr, attrs, real):
        unit = units.get(name.rstrip("'")) if not name.endswith("'") else None
        if unit:
            used_units.add(unit)
            real += f" unit={quoteattr(unit)}"
        text = f" description={quoteattr(described[name])}" if described.get(name) else ""
        variables.append(f'    <ScalarVariable name={quoteattr(name)} valueReference="{vr}"{text} {attrs}>\n'
                         f'      <Real{real}/>\n    </ScalarVariable>')

    nx, npar = compiled.nx, compiled.np
    # a scene output that is a state ("output hinge.phi") is that state variable with causality output
    asked = set(compiled.y_names) | {o.name for o in (sc.outputs if sc is not None else ())}
    state_outputs = [i for i, name in enumerate(compiled.x_names) if name in asked]
    for i, name in enumerate(compiled.x_names):
        causality = "output" if i in state_outputs else "local"
        variable(name, i, f'causality="{causality}" variability="continuous" initial="exact"',
                 f' start="{_number(x0[i])}"')
    for i, name in enumerate(compiled.x_names):
        variable(f"{name}'", nx + i, 'causality="local" variability="continuous" initial="calculated"',
                 f' derivative="{i + 1}"')
    hidden = internal_parameters(compiled)
    for i, name in enumerate(compiled.p_names):
        if i in hidden:
            continue
        variable(name, 2 * nx + i, 'causality="parameter" variability="tunable" initial="exact"',
                 f' start="{_number(p0[i])}"')
    listed = 2 * nx + npar - len(hidden)  # ScalarVariables so far (their 1-based index in ModelVariables)
    index, outputs = listed, [i + 1 for i in state_outputs]
    for i, name in enumerate(compiled.y_names):
        if name not in compiled.x_names:
            variable(name, 2 * nx + npar + i, 'causality="output" variability="continuous" initial="calculated"',
                     "")
            index += 1
            outputs.append(index)
    derivatives = [nx + i + 1 for i in range(nx)]
    unknowns = sorted(derivatives + [i for i in outputs if i > listed])
    step = settings["sample"] or settings["t_end"] / 500
    description = f" description={quoteattr(model.description)}" if model.description else ""
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<fmiModelDescription fmiVersion="2.0" modelName={quoteattr(model.name)} guid="{guid}"{description}',
        f'  generationTool="Baukasten {mbs.__version__}" variableNamingConvention="flat"'
        f' numberOfEventIndicators="{len(compiled.events)}">',
        f'  <ModelExchange modelIdentifier="{ident}" canGetAndSetFMUstate="true"'
        ' canNotUseMemoryManagementFunctions="true">',
        f'    <SourceFiles><File name="{SOURCE}"/></SourceFiles>',
        '  </ModelExchange>',
        f'  <CoSimulation modelIdentifier="{ident}" canHandleVariableCommunicationStepSize="true"'
        ' canGetAndSetFMUstate="true" canNotUseMemoryManagementFunctions="true">',
        f'    <SourceFiles><File name="{SOURCE}"/></SourceFiles>',
        '  </CoSimulation>',
    ]
    if used_units:
        lines += ["  <UnitDefinitions>"] + [f"    <Unit name={quoteattr(u)}/>" for u in sorted(used_units)]
        lines += ["  </UnitDefinitions>"]
    lines += [f'  <DefaultExperiment startTime="0" stopTime="{_number(settings["t_end"])}"'
              f' tolerance="{_number(settings["rtol"])}" stepSize="{_number(step)}"/>',
              "  <ModelVariables>", *variables, "  </ModelVariables>", "  <ModelStructure>"]
    if outputs:
        lines += ["    <Outputs>"] + [f'      <Unknown index="{i}"/>' for i in outputs] + ["    </Outputs>"]
    lines += ["    <Derivatives>"] + [f'      <Unknown index="{i}"/>' for i in derivatives] + ["    </Derivatives>"]
    lines += ["    <InitialUnknowns>"] + [f'      <Unknown index="{i}"/>' for i in unknowns]
    lines += ["    </InitialUnknowns>", "  </ModelStructure>", "</fmiModelDescription>", ""]
    return "\n".join(lines)


def _defaults_header(guid: str, x0, p0, rtol: float, atol: float, events=None) -> str:
    def array(name, values):
        body = ", ".join(_number(v) for v in values) or "0.0"
        return f"static const double {name}[] = {{{body}}};"

    def integers(name, values):
        return f"static const int {name}[] = {{{', '.join(str(int(v)) for v in values) or '0'}}};"
    lines = ["/* start values and settings of this FMU, written by mbs/fmu.py */",
             f'#define MBS_FMU_GUID "{guid}"', f"#define MBS_FMU_RTOL {_number(rtol)}",
             f"#define MBS_FMU_ATOL {_number(atol)}", array("MBS_FMU_X0", x0), array("MBS_FMU_P0", p0)]
    if events is not None:  # the event table (event_table): what mbs_fmu.c applies at each indicator's crossing
        lines += [f"#define MBS_FMU_FROZEN {events['frozen']}"]
        lines += [integers(f"MBS_FMU_{key.upper()}", events[key])
                  for key in ("directions", "flag", "inclusive", "handled", "terminal", "first", "index", "slot",
                              "target")]
        names = ", ".join('"' + re.sub(r'[^\w.]', '_', n) + '"' for n in events["names"])
        lines += [f"static const char *const MBS_FMU_EVENT_NAMES[] = {{{names}}};"]
    return "\n".join(lines + [""])


def event_table(compiled) -> dict | None:
    """The events as mbs_fmu.c applies them (None without events): per indicator its direction, a switch's
    branch flag (p index or -1), whether the C sampling loop may restart from it itself (handled: it assigns
    run-time values only, runtime/event_loop.c_restart_tables) and whether it ends the run; per event its
    assignments target[j] (0: p, 1: x) [index[j]] <- slot[j] of mbs_event_actions, grouped by first.  A switched
    friction element (compiler/friction.py) is refused: after its events the run checks the held forces in Python
    (runtime/friction.py), which an FMU, running without Python, cannot do; an error, never a silently different
    answer."""
    from mbs.runtime.event_loop import c_restart_tables
    from mbs.runtime.friction import is_friction_event
    if not compiled.events:
        return None
    refused = [e.name for e in compiled.events if is_friction_event(compiled, e.name)]
    if refused:
        names = ", ".join(f"'{n}'" for n in refused)
        which = f"events {names} are" if len(refused) > 1 else f"event {names} is"
        raise MbsError([Diagnostic("error", f"mbs fmu: {which} the stick/slip switch of a friction element "
                                            f"(coulomb(...)), whose held forces the run checks after every event in "
                                            f"Python (runtime/friction.py); an FMU runs without Python and cannot "
                                            f"export it yet (simulate the model with mbs simulate, or write the "
                                            f"stick and slip as events of a mode, as library/examples/stick_slip.mbs "
                                            f"does)", None)])
    tables = c_restart_tables(compiled)
    first, index, slot, target = [0], [], [], []
    for spec in compiled.events:
        for array, i, value_slot in spec.assignments:
            index.append(i)
            slot.append(value_slot)
            target.append(int(array == "x"))
        first.append(len(index))
    return dict(frozen=compiled.p_names.index("switch.frozen") if "switch.frozen" in compiled.p_names else -1,
                directions=[e.direction for e in compiled.events], flag=[e.switch for e in compiled.events],
                inclusive=[int(e.inclusive) for e in compiled.events],
                # (2, a prescribed motion's switch on a model with loops, that the Python run projects after in C:
                # handed back here, and fmu_apply_events projects after it)
                handled=[int(h == 1) for h in tables[0]] if tables is not None else [0] * len(compiled.events),
                terminal=[int(e.terminal) for e in compiled.events], first=first, index=index, slot=slot,
                target=target, names=[e.name for e in compiled.events])


def internal_parameters(compiled) -> set[int]:
    """p indices that are run-time machinery, not the model's parameters: the switches' branch flags and the
    frozen flag (compiler/events.py); the FMU sets them itself and does not list them."""
    flags = {e.switch for e in compiled.events if e.switch >= 0}
    return flags | ({compiled.p_names.index("switch.frozen")} if "switch.frozen" in compiled.p_names else set())


#: The one translation unit of the binary; it includes model.c, fmu_defaults.h and the run time's files.
SOURCE = "mbs_fmu.c"


def sources(model_c: str, defaults: str, hook_files: dict[str, str]) -> dict[str, str]:
    """{file name: text} the binary is built from: model.c (the generated equations, including the hooks'
    files), fmu_defaults.h, the hooks' C files, mbs_fmu.c and the run-time files it includes."""
    files = {"model.c": model_c, "fmu_defaults.h": defaults, **hook_files}
    pending = [SOURCE]
    while pending:
        name = pending.pop()
        if name in files or not (C_DIR / name).is_file():
            continue
        files[name] = (C_DIR / name).read_text(encoding="utf-8")
        pending += re.findall(r'^\s*#\s*include\s+"([^"]+)"', files[name], flags=re.M)
    return files


def _compile(files: dict[str, str], library: str, tmp: Path) -> bytes:
    for name, text in files.items():
        (tmp / name).write_text(text, encoding="utf-8")
    cmd = [*compiler_command(), *FLAGS, f"-I{tmp}", str(tmp / SOURCE), "-o", str(tmp / library), "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise MbsError([Diagnostic("error", f"the C compiler failed on the FMU:\n{proc.stderr}", None)])
    return (tmp / library).read_bytes()


def export_fmu(system, scene: str | None, path: str | Path, hooks=None) -> Path:
    """Write the FMU (a zip: modelDescription.xml, binaries/<platform>/<id>.so, sources/) atomically. hooks:
    the C files of the model's user hooks ({name: 'file.c'}), compiled into the binary."""
    from mbs.runtime.hooks import bind, require_c
    from mbs.system import _settings
    binding = bind(system.model.hooks, hooks, system.model.name)  # before anything is built
    require_c(binding, "an FMU runs without Python")
    compiled = system.compile(scene, hooks=binding)
    gen = system.generate(scene)
    x0, p0 = start_state(system, scene, binding)
    settings = _settings(system.scene(scene), None, None, None, None, None)
    hook_files = {name: text for name, (_, text) in binding.c_file_names().items()} if binding is not None else {}
    model_c = gen.whole_source + ("\n/* ---- user hooks ---- */\n" + binding.c_source(include=True) + "\n"
                              if binding is not None else "")
    guid_source = model_c + repr(sorted(hook_files.items())) + repr((list(x0), list(p0), compiled.x_names,
                                                                     compiled.y_names))
    digest = hashlib.sha256(guid_source.encode()).hexdigest()
    guid = f"{{{digest[:8]}-{digest[8:12]}-{digest[12:16]}-{digest[16:20]}-{digest[20:32]}}}"
    ident = identifier(system.model.name)
    suffix = {"darwin": ".dylib", "win32": ".dll"}.get(sys.platform, ".so")
    defaults = _defaults_header(guid, x0, p0, settings["rtol"], settings["atol"], event_table(compiled))
    files = sources(model_c, defaults, hook_files)
    with tempfile.TemporaryDirectory() as tmp:
        binary = _compile(files, ident + suffix, Path(tmp))
    xml = model_description(system, scene, guid, x0, p0, binding)
    with atomic_path(path) as tmp_path, zipfile.ZipFile(tmp_path, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("modelDescription.xml", xml)
        z.writestr(f"binaries/{platform_folder()}/{ident}{suffix}", binary)
        for name, text in files.items():
            z.writestr(f"sources/{name}", text)
    return Path(path)


__all__ = ["export_fmu", "model_description", "platform_folder", "identifier", "platform"]
