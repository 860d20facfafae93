"""Validated models kept by the content of every file they were read from, so that a second run of a model file
neither parses nor validates it (nor loads the parser and the validator).

Reading the Iltis (five files: lark, the parser and the validator loaded, the text parsed and validated) cost
0.65 s of the 1.5 s of CPU a warm `mbs simulate` took (bench/iltis.py); with this cache it needs none of it. An
entry keeps what language.frontend.check gives for a file (its models with their scenes, its components' names,
its warnings), as a snapshot (language/snapshot.py: plain JSON data, nothing in it runs code when read), under a
key of:

* the path as given and the working directory (messages show paths relative to it), and the file's content;
* the code that reads and validates (every file of mbs.language and this module), where it is installed (the
  shipped library it imports from is found next to it) and the versions of lark, Baukasten and Python.

It is used only while every file the check read (the imports, their imports) still has the content it was read
with, and no file has appeared where an import looked first and found none (it would be imported instead): any
edit of any of them reads the model again. A file with errors is never kept, so its errors are reported, located
(file:line:col), on every run. The entry also keeps each model's content digest (Model.content_digest), on which
the derivation cache keys: a warm start neither writes the model's text nor hashes it.

Entries are JSON files in the build cache next to the derivations (runtime/cache.py: written atomically with a
record of size and SHA-256, read only when intact and writable by their owner alone; `mbs cache` lists, cleans and
verifies them). A damaged one is read again from the model's files, with a note.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import os
from pathlib import Path

from mbs.base.cachedir import cache_folder
from mbs.language import snapshot
from mbs.language.checked import CheckResult, pick
from mbs.language.model import Model
from mbs.runtime import cache as _cache

#: Bump when what is kept, or how it is read back, changes in a way the hashed sources do not show.
FORMAT = 1
_log = logging.getLogger("mbs.cache")
_LANGUAGE = str(Path(snapshot.__file__).resolve().parent)


def load(path: str | Path, model: str | None = None, *, cache_dir=None) -> Model:
    """The named model of a file (or its first), as language.frontend.load gives it, from the cache when the
    file and everything it imports are unchanged."""
    return pick(check(path, cache_dir=cache_dir), model, str(path))


def check(path: str | Path, *, cache_dir=None) -> CheckResult:
    """language.frontend.check, taken from the model cache when every file it read is unchanged."""
    try:
        content = Path(path).read_bytes()
    except OSError:  # the front end reports it, located
        return _check(path)
    key = _cache.digest(("format", str(FORMAT)), ("code", model_fingerprint()), ("code location", _LANGUAGE),
                        ("path", str(path)), ("cwd", os.getcwd()), ("content", hashlib.sha256(content).hexdigest()))
    folder = cache_folder(cache_dir)
    entry = folder / f"{_cache.CHECKED_PREFIX}{key[:32]}.json"
    result = _read(entry, key)
    if result is not None:
        _log.info("model file %s: cache hit (%s)", path, entry.name)
        return result
    from mbs.language.frontend import check_sources
    result, sources = check_sources(path)
    _write(entry, key, result, sources, path)
    return result


@functools.lru_cache(maxsize=1)
def model_fingerprint() -> str:
    """SHA-256 of the code that reads and validates model files, and of the versions it runs with."""
    import mbs.language
    return _cache.code_fingerprint([Path(__file__), *_cache.package_files(mbs.language)], ("lark",))


def _check(path) -> CheckResult:
    from mbs.language.frontend import check
    return check(path)


def _read(entry: Path, key: str) -> CheckResult | None:
    """The result kept in an intact, current entry (None: none, or one whose files changed; a note when one is
    there but unusable)."""
    if not entry.exists():
        return None
    payload, damage = _cache.read_derived(entry)
    if payload is not None and payload.get("key") != key:
        payload, damage = None, "its key differs"
    if payload is not None and not _unchanged(payload):
        _log.info("model file: %s is out of date (an imported file changed)", entry.name)
        return None
    result = None
    if payload is not None:
        try:
            result = snapshot.from_plain(payload["snapshot"])
            if not isinstance(result, CheckResult) or len(payload["digests"]) != len(result.models):
                raise ValueError("it holds no checked models")
        except (KeyError, TypeError, ValueError) as exc:
            damage, result = str(exc), None
    if result is None:
        _log.warning(f"note: the cached model {entry.name} is not used ({damage}); reading the model again")
        return None
    for model, digest in zip(result.models, payload["digests"]):
        model.__dict__["content_digest"] = digest  # what the cached_property would compute, computed before
    return result


def _unchanged(payload: dict) -> bool:
    """Whether every file the entry was read from has the same content, and no import would now find a file
    where it found none."""
    for name, digest in payload["files"]:
        try:
            if hashlib.sha256(Path(name).read_bytes()).hexdigest() != digest:
                return False
        except OSError:
            return False
    return not any(os.path.exists(name) for name in payload["missing"])


def _write(entry: Path, key: str, result: CheckResult, sources, path) -> None:
    try:
        plain = snapshot.to_plain(result)
    except snapshot.NotPlain as exc:
        _log.info("model file %s is not cached (%s)", path, exc)
        return
    payload = {"key": key, "files": [[str(p), hashlib.sha256(text.encode()).hexdigest()]
                                     for p, text in sources.texts.items()],
               "missing": [str(p) for p in sources.missing], "digests": [m.content_digest for m in result.models],
               "snapshot": plain}
    label = f"{', '.join(m.name for m in result.models) or 'components'} ({Path(path).name}, validated)"
    try:
        _cache.write_derived(entry, payload, label)
    except OSError as exc:  # a read-only cache still runs, only slower next time
        _log.warning(f"note: the model file {path} is not cached ({exc.strerror or exc})")
