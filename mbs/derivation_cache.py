"""Derived equations kept by the model's content, so that a second run of a model does not derive them again.

Deriving the Iltis (lowering, the symbolic Newton-Euler equations, code generation) takes about 2 s; everything
after it (the compiled library in the build cache, equilibrium, integration) takes less. The generated code and
what the run needs besides it (state, parameter and output names, the start's layout, the event table) are kept
under a key of everything that can change them:

* the validated model with its scenes left out (Model.content_digest, the SHA-256 of its text representation):
  every imported file's content is in it (the spans' positions too, so an edit anywhere gives a new key), and the
  path the model was read from (the C's header comment names it);
* of the scene only what the derivation reads: its inputs and outputs. Scenes that differ in parameters, initial
  values or settings share one entry (and one compiled library);
* the options that change the code (Jacobian, parameter Jacobian, dynamics functions, frames);
* the derivation's own source (every file of mbs.language, mbs.compiler, this module and mbs.pipeline) and the
  versions of sympy and Python.

The equations and a scene's outputs are kept apart. pipeline.generate writes the equations' C first and the
outputs, lowered onto the end of the lowering's tape, as the last part of the file; the equations' entry is keyed
by all of the above but the outputs, an outputs entry by the equations' key and the outputs. A scene asking for
other outputs finds the equations' entry, lowers the model again (the outputs are expressions on its tape) and
writes only its outputs' part: the same text a whole derivation gives, whichever scene came first. It derives the
equations of motion again without writing their code, since the outputs share their temporaries on the tape (with
loops the outputs' part is written with a stand-in for them, pipeline.outputs_equations, as generate writes it: the
outputs read the loop solver's accelerations and multipliers at run time; a tree's NumPy module holds the outputs
and the equations in one).
The build compiles that part as a unit of its own (runtime/translation_units.py), so nothing else recompiles.
Outputs that cannot stand apart (they call a user hook or add a switch) are kept with the whole file under the
outputs' key.

Entries are JSON files in the build cache (runtime/cache.py: checked against their record, read only when the
user alone can write them, listed, cleaned and verified by `mbs cache`); a damaged one is derived again with a
note. A model whose content has no stable text (an object without a value representation) is never cached.
What the symbolic stages themselves hold (Generated.lowered, .equations, .constraints) is not kept: a caller that
asks for them gets them derived again, once.
"""

from __future__ import annotations

import dataclasses
import functools
import logging
from pathlib import Path

from mbs.base.cachedir import cache_folder
from mbs.language import model as M
from mbs.runtime import cache as _cache

from . import pipeline

#: Bump when what is kept, or how it is read back, changes in a way the hashed sources do not show.
FORMAT = 2
_log = logging.getLogger("mbs.cache")
_PACKAGE = Path(__file__).resolve().parent.parent


@functools.lru_cache(maxsize=1)
def derivation_fingerprint() -> str:
    """SHA-256 of the code that derives: the language and compiler packages, this module, the pipeline, and the
    versions of sympy (its simplifications shape the generated text), Baukasten and Python."""
    import mbs.compiler
    import mbs.language
    files = [Path(__file__), Path(pipeline.__file__), *_cache.package_files(mbs.language),
             *_cache.package_files(mbs.compiler)]
    return _cache.code_fingerprint(files, ("sympy",))


def derivation_key(model: M.Model, scene: M.Scene | None, options: dict) -> str | None:
    """The hex SHA-256 of everything the derivation reads, the scene's outputs included (None: the model has no
    stable text to key on)."""
    equations = equations_key(model, scene, options)
    return None if equations is None else outputs_key(equations, scene)


def equations_key(model: M.Model, scene: M.Scene | None, options: dict) -> str | None:
    """The hex SHA-256 of everything the equations' part of the derivation reads: all but the scene's outputs
    (None: the model has no stable text to key on)."""
    content = model.content_digest
    inputs = repr(scene.inputs) if scene is not None else "no scene"
    if content is None or " at 0x" in inputs:  # an object's address: the text differs in every process
        return None
    return _cache.digest(("format", str(FORMAT)), ("code", derivation_fingerprint()), ("path", model.span.source.path),
                   ("model", content), ("inputs", inputs), ("options", repr(sorted(options.items()))))


def outputs_key(equations: str, scene: M.Scene | None) -> str | None:
    """The hex SHA-256 of the equations' key and the outputs a scene asks for (without their spans: scenes
    asking for the same outputs in other lines share an entry)."""
    wanted = repr([(o.name, o.value, o.unit) for o in scene.outputs]) if scene is not None else "no scene"
    if " at 0x" in wanted:
        return None
    return _cache.digest(("equations", equations), ("outputs", wanted))


def generate(model: M.Model, scene: M.Scene | None = None, *, cache_dir=None, jacobian: bool | None = None,
             parameter_jacobian: bool = False, dynamics: bool = False, frames: tuple[str, ...] = (),
             equations_ready=None, closed_form: bool = True, cold_apart: bool = False) -> pipeline.Generated:
    """pipeline.generate, taken from the derivation cache when the same content was derived before; when only
    the equations were (another scene's outputs), the outputs are derived on top of them
    (pipeline.generate_outputs) and the equations' part of the code is taken from the cache. `equations_ready`:
    called with the equations' part of the code before the outputs are derived (pipeline.generate).
    cold_apart: as for pipeline.generate; the whole file (Generated.whole_source) is then this function's with
    cold_apart False, kept in the cache by content like any other derivation."""
    if jacobian is None:  # the scene's integrator decides; resolved here so the key holds what the code holds
        jacobian = pipeline.needs_jacobian(scene)
    options = dict(jacobian=jacobian, parameter_jacobian=parameter_jacobian, dynamics=dynamics,
                   frames=tuple(frames), closed_form=closed_form)
    if cold_apart:  # (in the options only when set: the eager ones read as before)
        options["cold_apart"] = True
    generated = _generate(model, scene, cache_dir, options, equations_ready)
    if not generated.cold_apart:
        return generated
    whole = functools.partial(generate, model, scene, cache_dir=cache_dir, **{**options, "cold_apart": False})
    return dataclasses.replace(generated, complete=whole)


def _generate(model: M.Model, scene: M.Scene | None, cache_dir, options: dict, equations_ready) -> pipeline.Generated:
    """generate with its options resolved."""
    eq_key = equations_key(model, scene, options)
    out_key = outputs_key(eq_key, scene) if eq_key is not None else None
    if out_key is None:
        return pipeline.generate(model, scene, **options)
    folder = cache_folder(cache_dir)
    eq_path, out_path = (folder / f"{_cache.DERIVED_PREFIX}{k[:32]}.json" for k in (eq_key, out_key))
    derive = functools.partial(_derive_symbolic, model, scene, options)
    numpy = functools.partial(_print_numpy, model, scene, options)
    outputs = _read(out_path, out_key)
    if outputs is not None and outputs.get("kind", "whole") == "whole":
        _log.info("derivation of %s: cache hit (%s)", model.name, out_path.name)
        return _from_payload(model, scene, outputs, derive, numpy)
    equations = _read(eq_path, eq_key)
    if outputs is not None and equations is not None:
        _log.info("derivation of %s: cache hit (equations %s, outputs %s)", model.name, eq_path.name, out_path.name)
        return _joined(model, scene, equations, outputs, derive, numpy)
    if equations is not None:
        from mbs.compiler.ccode import NotSeparable
        _log.info("derivation of %s: the equations from the cache (%s), the scene's outputs derived on them",
                  model.name, eq_path.name)
        if equations_ready is not None:
            equations_ready(equations["c_source"])
        try:
            c_outputs, print_numpy, y_names, symbolic = pipeline.generate_outputs(
                model, scene, equations["c_source"], **options)
        except NotSeparable:
            pass
        else:
            outputs = {"key": out_key, "kind": "outputs", "equations": eq_key, "c_outputs": c_outputs,
                       "numpy_source": None, "y_names": list(y_names)}
            _write(out_path, outputs, model, scene)
            return _joined(model, scene, equations, outputs, derive if symbolic is None else lambda: symbolic,
                           print_numpy)
    generated = pipeline.generate(model, scene, **options, equations_ready=equations_ready)
    payload = _payload(generated, out_key)
    if generated.outputs_at is not None:  # the equations apart, for scenes that ask for other outputs
        equations = {**payload, "key": eq_key, "kind": "equations",
                     "c_source": generated.c_source[:generated.outputs_at - 1]}
        del equations["numpy_source"], equations["y_names"]
        _write(eq_path, equations, model, None)
        payload = {"key": out_key, "kind": "outputs", "equations": eq_key,
                   "c_outputs": generated.c_source[generated.outputs_at:], "numpy_source": generated.numpy_text,
                   "y_names": list(generated.y_names)}
    _write(out_path, payload, model, scene)
    return generated


def _read(path: Path, key: str) -> dict | None:
    """The payload of an intact entry with this key (None: none, with a note when one is there but unusable)."""
    if not path.exists():
        return None
    payload, damage = _cache.read_derived(path)
    if payload is not None and payload.get("key") == key:
        return payload
    _log.warning(f"note: the cached derivation {path.name} is not used ({damage or 'its key differs'}); "
                 "deriving the equations again")
    return None


def _write(path: Path, payload: dict, model: M.Model, scene: M.Scene | None) -> None:
    try:
        _cache.write_derived(path, payload, _label(model, scene))
    except OSError as exc:  # a read-only cache still runs, only slower next time
        _log.warning(f"note: the derivation of {model.name} is not cached ({exc.strerror or exc})")


def _derive_symbolic(model, scene, options) -> pipeline.Symbolic:
    return pipeline.generate(model, scene, **options).symbolic


def _print_numpy(model, scene, options) -> str:
    """The NumPy module of a derivation taken from the cache without one (a run on the C back end never printed
    it): derived again, for the rare caller on the NumPy back end."""
    return pipeline.generate(model, scene, **options).numpy_source


def _label(model: M.Model, scene: M.Scene | None) -> str:
    where = Path(model.span.source.path).name
    return f"{model.name} ({where}{', scene ' + scene.name if scene is not None else ', equations'})"


def _payload(gen: pipeline.Generated, key: str) -> dict:
    return {"key": key, "kind": "whole", "c_source": gen.c_source, "numpy_source": gen.numpy_text,
            "q_names": gen.q_names, "v_names": gen.v_names, "p_names": gen.p_names, "y_names": gen.y_names,
            "layout": dataclasses.asdict(gen.layout), "events": [dict(e) for e in gen.events]}


def _joined(model, scene, equations: dict, outputs: dict, derive, numpy) -> pipeline.Generated:
    """The Generated of an equations entry and an outputs entry: the code is the one text generate gives."""
    c_source = pipeline.join_parts(equations["c_source"], outputs["c_outputs"])
    payload = {**equations, "c_source": c_source, "numpy_source": outputs["numpy_source"],
               "y_names": outputs["y_names"]}
    return dataclasses.replace(_from_payload(model, scene, payload, derive, numpy),
                               outputs_at=len(equations["c_source"]) + 1)


def _from_payload(model, scene, payload: dict, derive, numpy) -> pipeline.Generated:
    """numpy: prints the NumPy module when the entry has none (None: the C back end's run did not print it)."""
    layout = payload["layout"]
    rows = layout["constraint_rows"]
    state = pipeline.StateLayout(tuple(layout["q_symbols"]), tuple(layout["v_symbols"]),
                                 tuple((body, tuple(slots)) for body, slots in layout["quaternions"]),
                                 tuple(layout["cuts"]), tuple(rows) if rows is not None else None,
                                 tuple(layout.get("z_symbols", ())))
    events = tuple({**e, "assignments": tuple(tuple(a) for a in e["assignments"])} for e in payload["events"])
    return pipeline.Generated(model, scene, payload["c_source"], payload.get("numpy_source"),
                              tuple(payload["q_names"]), tuple(payload["v_names"]), tuple(payload["p_names"]),
                              tuple(payload["y_names"]), state, events, derive, print_numpy=numpy)
