"""The build cache's size bound: when the cache grows past it, the least recently used entries are removed.

Without a bound the cache only grows (a developer's held 27,000 files, 1.9 GB, after a few weeks of work: every
edit of a model leaves its former library, objects and derivations behind). The bound is ``$MBS_CACHE_MAX_SIZE``
(``500M``, ``2G``, ``1.5GiB``; ``0``: none), by default DEFAULT_MAX_SIZE, 1 GB: the Iltis with all its entries
(library, inspection copy of the C, unit objects, derived equations, validated model) takes about 10 MB, a small
model well under 1 MB, so a gigabyte keeps a hundred versions of the largest model; ccache's 5 GB is sized for
C projects, not for a laptop's cache of generated models. `mbs cache clean --max-size` applies another bound once.

Entries are removed whole (a library with its record and C copy, an object with its record, a derivation, a
validated model: runtime/cache.py entries), the least recently used first, down to TARGET of the bound, so that
the next stores do not walk again at once. "Used" is the newest modification time of an entry's files: a hit sets
it (touch: one os.utime, on the module or JSON entry cache.problem and cache.read_derived have just checked), since
access times are often not kept (relatime, noatime). With no bound (0) nothing is touched, recorded or removed.

Cheap and rare. A walk costs tens of microseconds a file (bench/cache_bound.py: 24,000 files, 0.83 s on a loaded
machine, 2.9 times a bare stat of each), so it is never on the hot path: a hit (a warm `mbs simulate`) only touches
its entries (its CPU time with the bound 0.996 of that without, medians of 21). A fresh store appends its size
to LEDGER (one short O_APPEND write), whose first line is the total the last walk measured; the cache is walked,
and evicted, only when the ledger's sum passes the bound (by at least what an eviction frees since the last walk,
so that a cache whose every entry is in use is not walked on every store), when it has no valid first line (a new cache, one filled
by an older version), or every WALK_EVERY stores (other writers, removals and lost lines make the sum drift).

Safe beside other processes: one walks at a time (a non-blocking lock on the folder; the others skip); an entry
used within GRACE seconds is never removed automatically (another process may be about to link an object it has
just checked; the entry just stored is kept in any case); temporaries (a build's folder, a file being written
atomically) are removed only when older than STALE_TEMPORARY; an error while evicting never fails the store that
triggered it (it is logged at debug level). A library loaded by a running process may be removed (its mapping
stays valid on POSIX; Windows refuses, and the entry is skipped).
"""

from __future__ import annotations

import functools
import logging
import os
import re
import shutil
import time
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from mbs.base.atomic import write_text_atomic

MAX_SIZE_ENV = "MBS_CACHE_MAX_SIZE"
#: The bound when $MBS_CACHE_MAX_SIZE is not set (bytes; see the module's docstring for why).
DEFAULT_MAX_SIZE = 1_000_000_000
#: An eviction goes down to this fraction of the bound.
TARGET = 0.9
#: Seconds: an entry used more recently is not removed by the automatic eviction.
GRACE = 600.0
#: Seconds: an older temporary is left over by a process that was killed (the longest compile of a unit measured
#: here took 14 s of CPU) and is removed by a walk; a younger one may be being written.
STALE_TEMPORARY = 3600.0
#: A walk after this many stores, whatever the ledger says.
WALK_EVERY = 1000
#: The file in the cache folder with the last walk's total and the sizes stored since.
LEDGER = "size-ledger"
_TOTAL = "total "
_log = logging.getLogger("mbs.cache")
_UNITS = {"": 1, "k": 10**3, "m": 10**6, "g": 10**9, "t": 10**12,
          "ki": 2**10, "mi": 2**20, "gi": 2**30, "ti": 2**40}


# ------------------------------------------------------------------------------------------ the bound
def parse_size(text: str) -> int:
    """Bytes of a size as ccache writes them: '500M', '2G', '1.5GiB', '100k', '0' (K, M, G, T: powers of 1000;
    Ki, Mi, Gi, Ti: of 1024; a trailing B allowed; bytes need it: '12345B'). Raises ValueError saying what is
    wrong."""
    match = re.fullmatch(r"\s*(\d+(?:\.\d*)?|\.\d+)\s*([kmgt]i?)?(b?)\s*", text, re.IGNORECASE)
    if match is None:
        raise ValueError(f"{text!r} is not a size (a number with a unit, K, M, G or T, e.g. 500M or 2G)")
    number, unit = float(match.group(1)), (match.group(2) or "").lower()
    if not unit and match.group(3) and number != int(number):
        raise ValueError(f"{text!r} is not a whole number of bytes")
    if not unit and not match.group(3) and number != 0:
        raise ValueError(f"{text!r} has no unit (500M, 2G: K, M, G, T are powers of 1000, Ki, Mi, Gi of 1024; "
                         "bytes: 12345B)")
    return int(number * _UNITS[unit])


def max_size() -> int:
    """The bound in bytes: $MBS_CACHE_MAX_SIZE, else DEFAULT_MAX_SIZE (also, with a warning, when the variable
    is not a size); 0: none."""
    return _max_size(os.environ.get(MAX_SIZE_ENV, "").strip())


@functools.lru_cache(maxsize=4)
def _max_size(text: str) -> int:
    if not text:
        return DEFAULT_MAX_SIZE
    try:
        return parse_size(text)
    except ValueError as exc:
        _log.warning(f"warning: {MAX_SIZE_ENV}: {exc}, or 0 for no bound; the build cache is bounded to the "
                     f"default, {format_size(DEFAULT_MAX_SIZE)}")
        return DEFAULT_MAX_SIZE


def max_size_origin() -> str:
    """Where max_size comes from, as `mbs cache` says it: '$MBS_CACHE_MAX_SIZE=500M' or 'the default'."""
    text = os.environ.get(MAX_SIZE_ENV, "").strip()
    try:
        parse_size(text)
    except ValueError:
        return "the default"
    return f"${MAX_SIZE_ENV}={text}"


def format_size(n: float) -> str:
    """'1.0 GB', '350.2 kB', '12 B' (powers of 1000, as `mbs cache` prints every size)."""
    for unit in ("B", "kB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return f"{n} B"


# ------------------------------------------------------------------------------------------ use and store
def touch(path: Path) -> None:
    """Record that a cached file is used now (its modification time; nothing when there is no bound)."""
    if max_size():
        try:
            os.utime(path)
        except OSError:  # a read-only cache, another user's file: its use is not recorded, nothing else
            pass


def stored(folder: Path, stem: str, size: int) -> None:
    """After a fresh store of `size` bytes to entry `stem`: add them to the ledger and, when it says the cache
    is past its bound (or it is time to measure again), walk and evict, keeping `stem`. Never raises."""
    limit = max_size()
    if not limit:
        return
    try:
        ledger = folder / LEDGER
        with open(ledger, "a", encoding="ascii") as f:
            f.write(f"{size}\n")
        ledger_sum = _ledger_sum(ledger)
        if ledger_sum is None or _due(*ledger_sum, limit):
            enforce(folder, limit, keep=(stem,))
    except Exception as exc:  # the bound is housekeeping: the build that stored has succeeded
        _log.debug("build cache %s: the size bound was not enforced (%s)", folder, exc, exc_info=True)


def _ledger_sum(ledger: Path) -> tuple[int, int, int] | None:
    """(the last walk's total, the bytes and the number of stores since) from the ledger; None: it has no walk's
    total first."""
    try:
        lines = ledger.read_text(encoding="ascii").splitlines()
        if not lines or not lines[0].startswith(_TOTAL):
            return None
        return int(lines[0][len(_TOTAL):]), sum(int(line) for line in lines[1:] if line), len(lines) - 1
    except (OSError, ValueError, UnicodeDecodeError):
        return None


def _due(walked: int, added: int, stores: int, limit: int) -> bool:
    """Whether to walk: past the bound, with at least what an eviction frees (the bound's last tenth) stored
    since the last walk (a walk that could not get under the bound, every entry being in use, is not repeated
    on every store); or after WALK_EVERY stores."""
    return (walked + added > limit and added > (1 - TARGET) * limit) or stores > WALK_EVERY


def enforce(folder: Path, limit: int, keep: tuple[str, ...] = ()) -> Eviction | None:
    """Walk the cache; past `limit` bytes remove the least recently used entries down to TARGET of it (sparing
    `keep` and those used within GRACE seconds) and the stale temporaries; write the ledger's new total. None:
    another process is walking it now."""
    with _walking(folder) as alone:
        if not alone:
            return None
        found = scan(folder)
        result = evict(found, int(limit * TARGET), keep=keep, grace=GRACE) if found.size > limit else \
            Eviction(0, 0, found.size)
        remove_stale_temporaries(found)
        write_text_atomic(folder / LEDGER, f"{_TOTAL}{result.left}\n")
        if result.removed:
            _log.debug("build cache %s: %d least recently used entries removed (%s), %s left (bound %s)", folder,
                       result.removed, format_size(result.freed), format_size(result.left), format_size(limit))
        return result


@contextmanager
def _walking(folder: Path):
    """Yields True when this process holds the folder's lock (a non-blocking flock on the folder itself, so no
    lock file is left behind); False when another holds it. Without flock (Windows) always True."""
    try:
        import fcntl
    except ImportError:
        yield True
        return
    fd = os.open(folder, os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            yield False
            return
        yield True
    finally:
        os.close(fd)  # (releases the lock)


def forget_ledger(folder: Path) -> None:
    """Remove the ledger (after `mbs cache clean`: the next store measures the cache again)."""
    try:
        os.unlink(folder / LEDGER)
    except OSError:
        pass


# ------------------------------------------------------------------------------------------ walk and evict
@dataclass(frozen=True)
class Stored:
    """An entry as the walk sees it: no record read, one stat per file."""

    name: str                       #: the entry's stem (runtime/cache.py entry_stem)
    kind: str                       #: runtime/cache.py kind_of
    folder: Path
    names: tuple[str, ...]          #: of its files (paths are made only for those removed: a walk makes none)
    size: int
    used: float                     #: the newest modification time of its files

    @property
    def files(self) -> tuple[Path, ...]:
        return tuple(self.folder / name for name in self.names)


@dataclass(frozen=True)
class Scan:
    entries: tuple[Stored, ...]     #: least recently used first
    temporaries: tuple[tuple[Path, float, int], ...]  #: (path, modification time, bytes) of each

    @property
    def size(self) -> int:
        return sum(e.size for e in self.entries)


@dataclass(frozen=True)
class Eviction:
    removed: int    #: entries removed
    freed: int      #: bytes
    left: int       #: bytes of the entries left


def is_temporary(name: str) -> bool:
    """A build's folder (runtime/build.py) or a file being written atomically (mbs.base.atomic)."""
    return name.startswith((".build-", ".prebuild-")) or (name.startswith(".") and name.endswith(".tmp"))


def scan(folder: Path) -> Scan:
    """Every entry of the cache folder with its size and last use, and the temporaries (one stat a file)."""
    from . import cache  # (it records hits and stores through this module)
    groups: dict[str, list] = {}  # stem -> [names, bytes, last use]
    temporaries = []
    try:
        listing = os.scandir(folder)
    except FileNotFoundError:
        return Scan((), ())
    with listing:
        for item in listing:
            _add(item, groups, temporaries, cache.entry_stem)
    entries = [Stored(stem, cache.kind_of(stem), folder, tuple(names), size, used)
               for stem, (names, size, used) in groups.items()]
    return Scan(tuple(sorted(entries, key=lambda e: e.used)), tuple(temporaries))


def _add(item: os.DirEntry, groups: dict, temporaries: list, entry_stem) -> None:
    """Count one file of the folder in its entry's group (or as a temporary)."""
    name = item.name
    try:
        if name[:1] == "." and is_temporary(name):
            st = item.stat(follow_symlinks=False)
            temporaries.append((Path(item.path), st.st_mtime, st.st_size if item.is_file() else 0))
            return
        stem = entry_stem(name)
        if stem is None or not item.is_file():
            return
        st = item.stat()
    except FileNotFoundError:  # removed by another process meanwhile
        return
    group = groups.get(stem)
    if group is None:
        groups[stem] = [[name], st.st_size, st.st_mtime]
    else:
        group[0].append(name)
        group[1] += st.st_size
        group[2] = max(group[2], st.st_mtime)


def evict(found: Scan, down_to: int, *, keep: tuple[str, ...] = (), grace: float = 0.0,
          now: float | None = None) -> Eviction:
    """Remove the least recently used entries of a scan until the rest take at most `down_to` bytes; spare those
    named in `keep` and those used within `grace` seconds of `now`. An entry that cannot be removed is skipped."""
    from . import cache
    now = time.time() if now is None else now
    left, removed, freed = found.size, 0, 0
    for entry in found.entries:
        if left <= down_to:
            break
        if entry.name in keep or now - entry.used < grace:
            continue
        try:
            gone = cache.remove_files(entry.files)
        except OSError as exc:  # (a library Windows keeps loaded; a folder gone read-only)
            _log.debug("build cache: %s not removed (%s)", entry.name, exc)
            continue
        left -= entry.size
        freed += gone
        removed += 1
    return Eviction(removed, freed, left)


def remove_stale_temporaries(found: Scan, now: float | None = None) -> int:
    """Remove the temporaries older than STALE_TEMPORARY (left by killed processes); how many."""
    now = time.time() if now is None else now
    removed = 0
    for path, mtime, _ in found.temporaries:
        if now - mtime < STALE_TEMPORARY:
            continue
        try:
            if path.is_dir() and not path.is_symlink():
                shutil.rmtree(path)
            else:
                os.unlink(path)
            removed += 1
        except OSError as exc:
            _log.debug("build cache: temporary %s not removed (%s)", path.name, exc)
    return removed
