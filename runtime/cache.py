"""The build cache's records: what each compiled model was when it was built, so that nothing damaged is loaded.

Next to every cached module ``mbs_model_<key><ext>`` the build writes ``mbs_model_<key>.json``: the module's
size and SHA-256, when it was built, and the model it came from. Before a cached module is loaded its size and
hash are compared with the record; a truncated or overwritten file (a full disk, a copy cut short, a stray
editor) would otherwise crash the process when loaded (a bus error, not an exception). A module without a
record, or with one that does not match, is rebuilt with a note, never loaded.

The objects of split builds (``mbs_object_<key>.o``, runtime/build.py) have records of the same kind and are
checked the same way before they are linked. Derived equations (``mbs_derived_<key>.json``,
mbs/derivation_cache.py) and validated models (``mbs_checked_<key>.json``, mbs/model_cache.py) are JSON files
that carry their record in their first line; both caches key their entries with `digest` and `code_fingerprint`.

The cache has a size bound (runtime/cache_bound.py): the checks before a use (`problem`, `read_derived`) record
the use when they pass, the stores (`record`, `write_derived`) tell the bound what they added.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import sys
import sysconfig
import time
from dataclasses import dataclass
from pathlib import Path

from mbs.base.atomic import write_text_atomic

from . import cache_bound as _bound

EXT_SUFFIX = sysconfig.get_config_var("EXT_SUFFIX") or ".so"
PREFIX = "mbs_model_"
DERIVED_PREFIX = "mbs_derived_"
CHECKED_PREFIX = "mbs_checked_"
OBJECT_PREFIX = "mbs_object_"


@dataclass(frozen=True)
class Entry:
    """One cached model: its module, record and the unit's C source (any may be missing)."""

    name: str               #: the module name, mbs_model_<key prefix> (mbs_derived_, mbs_checked_: JSON entries)
    module: Path            #: the compiled module (a derivation: its one file)
    record: dict | None     #: the JSON record (None: missing or unreadable)
    files: tuple[Path, ...]  #: every file of the entry (module, record, C unit)

    @property
    def kind(self) -> str:
        return kind_of(self.name)

    @property
    def size(self) -> int:
        return sum(p.stat().st_size for p in self.files if p.exists())

    @property
    def used(self) -> float:
        """Last use (seconds since the epoch): the newest modification time of its files (a hit touches one)."""
        return max((p.stat().st_mtime for p in self.files if p.exists()), default=0.0)

    @property
    def built(self) -> float:
        """Build time (seconds since the epoch): the record's, else the newest file's."""
        if self.record and isinstance(self.record.get("built"), (int, float)):
            return float(self.record["built"])
        return max((p.stat().st_mtime for p in self.files if p.exists()), default=0.0)

    @property
    def model(self) -> str:
        return str((self.record or {}).get("model") or "?")


def kind_of(name: str) -> str:
    """The kind of the entry named `name`: 'build' (a compiled model), 'object' (a compiled unit of one),
    'derivation' (derived equations and generated code) or 'model' (a file's validated models)."""
    if name.startswith(OBJECT_PREFIX):
        return "object"
    if name.startswith(CHECKED_PREFIX):
        return "model"
    return "derivation" if name.startswith(DERIVED_PREFIX) else "build"


def entry_stem(name: str) -> str | None:
    """The name of the entry a file of the cache folder belongs to (None: none, e.g. a temporary): a module,
    its record and its C copy share one, an object and its record one; a JSON entry is one file."""
    if name.startswith((DERIVED_PREFIX, CHECKED_PREFIX)):
        return name[:-5] if name.endswith(".json") else None
    if name.startswith((PREFIX, OBJECT_PREFIX)):
        return name[: -len(EXT_SUFFIX)] if name.endswith(EXT_SUFFIX) else name.rsplit(".", 1)[0]
    return None


def record_path(module: Path) -> Path:
    return module.with_name(module.name[: -len(EXT_SUFFIX)] + ".json") if module.name.endswith(EXT_SUFFIX) \
        else module.with_suffix(".json")


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def model_label(unit: str) -> str:
    """'pendulum (pz.mbs, scene swing)' from the header comment of the generated C."""
    name = re.search(r'Equations of motion of the model "([^"]*)"', unit)
    origin = re.search(r"^ \* From (.*)\.$", unit, re.MULTILINE)
    label = name.group(1) if name else "?"
    if origin is None:
        return label
    path, _, rest = origin.group(1).partition(", ")
    return f"{label} ({Path(path).name}{', ' + rest if rest else ''})"


def record(module: Path, key: str, unit: str, label: str | None = None) -> None:
    """Write the record of a module (or object) just built (atomically, after the file is in place)."""
    data = {"key": key, "size": module.stat().st_size, "sha256": sha256(module), "built": time.time(),
            "model": label or model_label(unit)}
    text = json.dumps(data, indent=1) + "\n"
    write_text_atomic(record_path(module), text)
    stem = entry_stem(module.name) or module.stem
    try:
        copy = module.with_name(stem + ".c").stat().st_size  # a module's C copy, stored just before it
    except OSError:
        copy = 0
    _bound.stored(module.parent, stem, data["size"] + len(text) + copy)


def object_path(cache: Path, key: str) -> Path:
    """Where the object of a split build's unit with this key is kept."""
    return cache / f"{OBJECT_PREFIX}{key[:32]}.o"


def store_object(built: Path, path: Path, label: str) -> None:
    """Move a freshly compiled object into the cache (atomically) and record it."""
    os.replace(built, path)
    record(path, path.stem[len(OBJECT_PREFIX):], "", label)


def read_record(module: Path) -> dict | None:
    try:
        data = json.loads(record_path(module).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def problem(module: Path, used: bool = True) -> str | None:
    """Why the cached module must not be loaded (None: it is what was built, and with `used` its use is recorded:
    this is the check before it is loaded or linked)."""
    data = read_record(module)
    if data is None:
        return "it has no build record"
    try:
        size = module.stat().st_size
    except OSError as exc:
        return f"it cannot be read ({exc.strerror})"
    if size != data.get("size"):
        return f"its size is {size} bytes, {data.get('size')} when it was built"
    try:
        digest = sha256(module)
    except OSError as exc:
        return f"it cannot be read ({exc.strerror})"
    if digest != data.get("sha256"):
        return "its content differs from what was built (SHA-256 mismatch)"
    if used:
        _bound.touch(module)
    return None


def entries(cache: Path) -> list[Entry]:
    """Every cached model and derivation in `cache`, oldest first."""
    if not cache.is_dir():
        return []
    groups: dict[str, list[Path]] = {}
    derived = []
    for path in cache.iterdir():
        stem = entry_stem(path.name)
        if stem is None or not path.is_file():
            continue
        if stem.startswith((DERIVED_PREFIX, CHECKED_PREFIX)):
            derived.append(Entry(stem, path, read_derived_record(path), (path,)))
        else:
            groups.setdefault(stem, []).append(path)
    main = {stem: cache / (stem + (".o" if stem.startswith(OBJECT_PREFIX) else EXT_SUFFIX)) for stem in groups}
    out = [Entry(stem, main[stem], read_record(main[stem]), tuple(sorted(files))) for stem, files in groups.items()]
    return sorted(out + derived, key=lambda e: e.built)


def entry_problem(entry: Entry) -> str | None:
    """Why an entry of either kind must not be loaded (None: it is what was written)."""
    if entry.kind in ("derivation", "model"):
        return read_derived(entry.module, used=False)[1]
    return problem(entry.module, used=False) if entry.module.exists() else "the compiled module is missing"


# ------------------------------------------------------------------------------------------ keys
def digest(*parts: tuple[str, str]) -> str:
    """The hex SHA-256 of labelled texts (each with its length, so that no two lists of parts run together)."""
    h = hashlib.sha256()
    for label, text in parts:
        h.update(f"{label}:{len(text)}:".encode())
        h.update(text.encode())
    return h.hexdigest()


def code_fingerprint(files, distributions: tuple[str, ...] = ()) -> str:
    """The hex SHA-256 of the code that makes an entry: these files (name, size, content), the installed
    versions of these distributions, Baukasten's version and Python's."""
    from mbs import __version__
    h = hashlib.sha256()
    for path in files:
        data = Path(path).read_bytes()
        h.update(f"{Path(path).name}:{len(data)}:".encode())
        h.update(data)
    versions = ", ".join(f"{name} {installed_version(name)}" for name in distributions)
    h.update(f"{versions}; baukasten {__version__}; python {sys.version}".encode())
    return h.hexdigest()


def package_files(package) -> list[Path]:
    """Every .py and .lark file of an imported package, sorted (what code_fingerprint hashes of it)."""
    folder = Path(package.__file__).parent
    return sorted(p for p in folder.rglob("*") if p.suffix in (".py", ".lark") and p.is_file())


def installed_version(distribution: str) -> str:
    """The installed version of a distribution ("?" if none), from its metadata folder next to the package
    (``NAME-VERSION.dist-info``: a glob, cheaper than loading importlib.metadata on every start); else from
    importlib.metadata."""
    import importlib.util
    spec = importlib.util.find_spec(distribution)
    if spec is not None and spec.origin:
        site = Path(spec.origin).parent.parent
        found = sorted(site.glob(f"{distribution}-*.dist-info"))
        if len(found) == 1:
            return found[0].name[len(distribution) + 1:-len(".dist-info")]
    import importlib.metadata
    try:
        return importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        return "?"


# ------------------------------------------------------------------------------------------ derivations
def write_derived(path: Path, payload: dict, model: str) -> None:
    """Write a derivation entry atomically: the record line, then the payload as JSON."""
    body = json.dumps(payload, separators=(",", ":")).encode()
    head = {"size": len(body), "sha256": hashlib.sha256(body).hexdigest(), "built": time.time(), "model": model}
    text = json.dumps(head) + "\n" + body.decode()
    write_text_atomic(path, text)
    _bound.stored(path.parent, entry_stem(path.name) or path.stem, len(text.encode()))


def read_derived_record(path: Path) -> dict | None:
    """The record line of a derivation entry (None: missing or unreadable)."""
    try:
        with open(path, "rb") as f:
            data = json.loads(f.readline())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def read_derived(path: Path, used: bool = True) -> tuple[dict | None, str | None]:
    """(payload, None) of an intact derivation entry that only its owner can write, else (None, why not); with
    `used` the use of an intact one is recorded (this is the check before it is used)."""
    try:
        owner_problem = _foreign(path)
        if owner_problem:
            return None, owner_problem
        raw = path.read_bytes()
    except OSError as exc:
        return None, f"it cannot be read ({exc.strerror})"
    head, _, body = raw.partition(b"\n")
    try:
        record = json.loads(head)
    except ValueError:
        return None, "it has no valid record"
    if not isinstance(record, dict) or len(body) != record.get("size"):
        return None, f"its size is {len(body)} bytes, {record.get('size') if isinstance(record, dict) else '?'} " \
                     "when it was written"
    if hashlib.sha256(body).hexdigest() != record.get("sha256"):
        return None, "its content differs from what was written (SHA-256 mismatch)"
    try:
        payload = json.loads(body)
    except ValueError:
        return None, "its content is not valid JSON"
    if not isinstance(payload, dict):
        return None, "its content is not a derivation"
    if used:
        _bound.touch(path)
    return payload, None


def _foreign(path: Path) -> str | None:
    """Why another user could have written the file (None: only its owner, who runs this, can)."""
    if not hasattr(os, "getuid"):  # no POSIX owners (Windows): the cache folder is in the user's profile
        return None
    st = path.stat()
    if st.st_uid != os.getuid():
        return "it belongs to another user"
    if st.st_mode & 0o022:
        return "others can write it"
    return None


def remove(entry: Entry) -> int:
    """Delete an entry's files (the record last: a half-removed entry is never trusted); bytes freed."""
    return remove_files(entry.files)


def remove_files(files) -> int:
    """Delete the files of an entry, the record (.json) last; bytes freed."""
    freed = 0
    for path in sorted(files, key=lambda p: p.suffix == ".json"):
        try:
            freed += path.stat().st_size
            os.unlink(path)
        except FileNotFoundError:
            pass
    return freed
