"""The build cache's size bound (runtime/cache_bound.py): parsed from $MBS_CACHE_MAX_SIZE, enforced after a store
when the ledger says the cache is past it, least recently used entries first, never what is in use."""

import logging
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mbs.runtime import cache, cache_bound

DAY = 86400.0
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def bound(monkeypatch):
    """Every test sets its own bound; the parsed values are cached per text, so the cache is cleared."""
    monkeypatch.delenv(cache_bound.MAX_SIZE_ENV, raising=False)
    cache_bound._max_size.cache_clear()
    yield
    cache_bound._max_size.cache_clear()


def _age(paths, days: float) -> None:
    when = time.time() - days * DAY
    for path in paths:
        os.utime(path, (when, when))


def _library(folder: Path, name: str, size: int, used_days_ago: float) -> list[Path]:
    """A fake compiled model: module, record (a real one, of its bytes) and C copy, last used so many days ago."""
    module = folder / f"{cache.PREFIX}{name}{cache.EXT_SUFFIX}"
    module.write_bytes(os.urandom(size))
    (folder / f"{cache.PREFIX}{name}.c").write_text("/* unit */\n")
    cache.record(module, name, "", f"fake {name}")
    files = [module, cache.record_path(module), folder / f"{cache.PREFIX}{name}.c"]
    _age(files, used_days_ago)
    return files


def _derived(folder: Path, name: str, size: int, used_days_ago: float) -> Path:
    path = folder / f"{cache.DERIVED_PREFIX}{name}.json"
    cache.write_derived(path, {"key": name, "blob": "x" * size}, f"fake {name}")
    _age([path], used_days_ago)
    return path


# ---------------------------------------------------------------------------------------------- the bound
@pytest.mark.parametrize("text, size", [("500M", 500_000_000), ("2G", 2_000_000_000), ("1.5GiB", 3 * 2**29),
                                        ("100k", 100_000), ("64KiB", 65536), ("2gb", 2_000_000_000), ("0", 0),
                                        (" 10 M ", 10_000_000), ("1T", 10**12), ("12345B", 12345), ("0B", 0)])
def test_sizes_are_read_as_ccache_writes_them(text, size):
    assert cache_bound.parse_size(text) == size


@pytest.mark.parametrize("text, why", [("abc", "is not a size"), ("500", "has no unit"), ("-1G", "is not a size"),
                                       ("1.5B", "not a whole number of bytes"),
                                       ("5X", "is not a size"), ("", "is not a size"), ("1e3M", "is not a size")])
def test_a_bad_size_says_what_is_wrong(text, why):
    with pytest.raises(ValueError, match=why):
        cache_bound.parse_size(text)


def test_the_bound_is_the_variable_else_the_default(monkeypatch):
    assert cache_bound.max_size() == cache_bound.DEFAULT_MAX_SIZE == 1_000_000_000
    monkeypatch.setenv(cache_bound.MAX_SIZE_ENV, "500M")
    assert cache_bound.max_size() == 500_000_000
    assert cache_bound.max_size_origin() == "$MBS_CACHE_MAX_SIZE=500M"
    monkeypatch.setenv(cache_bound.MAX_SIZE_ENV, "0")
    assert cache_bound.max_size() == 0


def test_a_bad_variable_is_a_warning_and_the_default(monkeypatch, caplog):
    monkeypatch.setenv(cache_bound.MAX_SIZE_ENV, "lots")
    with caplog.at_level(logging.WARNING, "mbs.cache"):
        assert cache_bound.max_size() == cache_bound.DEFAULT_MAX_SIZE
        assert cache_bound.max_size() == cache_bound.DEFAULT_MAX_SIZE
    assert caplog.text.count("MBS_CACHE_MAX_SIZE: 'lots' is not a size") == 1  # once per process
    assert "bounded to the default, 1.0 GB" in caplog.text
    assert cache_bound.max_size_origin() == "the default"


# ---------------------------------------------------------------------------------------------- least recently used
def test_eviction_removes_whole_entries_least_recently_used_first(tmp_path, monkeypatch):
    monkeypatch.setenv(cache_bound.MAX_SIZE_ENV, "0")  # (no eviction while the fakes are made)
    old = _library(tmp_path, "old", 10_000, used_days_ago=5)
    used = _library(tmp_path, "used", 10_000, used_days_ago=1)
    mid = _derived(tmp_path, "mid", 10_000, used_days_ago=3)
    found = cache_bound.scan(tmp_path)
    assert [e.name for e in found.entries] == [f"{cache.PREFIX}old", f"{cache.DERIVED_PREFIX}mid",
                                               f"{cache.PREFIX}used"]
    assert found.entries[0].kind == "build" and found.entries[1].kind == "derivation"
    result = cache_bound.evict(found, found.size - 1)  # one byte too many: the least recently used goes, whole
    assert result.removed == 1 and not any(p.exists() for p in old)
    assert mid.exists() and all(p.exists() for p in used)
    assert result.left == found.size - result.freed == cache_bound.scan(tmp_path).size
    assert cache_bound.evict(cache_bound.scan(tmp_path), 12_000).removed == 1 and not mid.exists()


def test_a_hit_records_the_use_and_verify_does_not(tmp_path, monkeypatch):
    monkeypatch.setenv(cache_bound.MAX_SIZE_ENV, "1G")
    module = _library(tmp_path, "lib", 1000, used_days_ago=4)[0]
    entry = _derived(tmp_path, "eq", 1000, used_days_ago=4)
    entries = cache.entries(tmp_path)
    assert all(cache.entry_problem(e) is None for e in entries)  # `mbs cache verify`: no use
    assert all(time.time() - e.used > 3 * DAY for e in entries)
    assert cache.problem(module) is None  # the check before a load or a link
    assert cache.read_derived(entry)[0]["key"] == "eq"  # the check before a derivation is used
    assert all(time.time() - p.stat().st_mtime < 60 for p in (module, entry))
    order = [e.name for e in cache_bound.scan(tmp_path).entries]
    _library(tmp_path, "older", 1000, used_days_ago=2)
    assert [e.name for e in cache_bound.scan(tmp_path).entries] == [f"{cache.PREFIX}older", *order]


def test_without_a_bound_nothing_is_touched_nor_recorded(tmp_path, monkeypatch):
    monkeypatch.setenv(cache_bound.MAX_SIZE_ENV, "0")
    module = _library(tmp_path, "lib", 1000, used_days_ago=4)[0]
    assert cache.problem(module) is None
    assert time.time() - module.stat().st_mtime > 3 * DAY
    assert not (tmp_path / cache_bound.LEDGER).exists()


# ---------------------------------------------------------------------------------------------- after a store
def test_a_store_walks_only_when_the_ledger_passes_the_bound(tmp_path, monkeypatch):
    walks = []
    scan = cache_bound.scan
    monkeypatch.setattr(cache_bound, "scan", lambda folder: walks.append(folder) or scan(folder))
    monkeypatch.setenv(cache_bound.MAX_SIZE_ENV, "50k")
    a = _derived(tmp_path, "a", 10_000, used_days_ago=3)  # a new cache: no ledger, so measured
    assert len(walks) == 1 and (tmp_path / cache_bound.LEDGER).read_text().startswith("total ")
    b = _derived(tmp_path, "b", 10_000, used_days_ago=2)
    c = _derived(tmp_path, "c", 10_000, used_days_ago=1)
    d = _derived(tmp_path, "d", 10_000, used_days_ago=1)
    assert len(walks) == 1  # 40 kB: no walk
    e = _derived(tmp_path, "e", 14_000, used_days_ago=0)  # 55 kB: past the bound, evicted down to 45 kB
    assert len(walks) == 2
    assert not a.exists() and all(p.exists() for p in (b, c, d, e))
    total = int((tmp_path / cache_bound.LEDGER).read_text().split()[1])
    assert total == cache_bound.scan(tmp_path).size <= 45_000


def test_a_measure_every_so_many_stores(tmp_path, monkeypatch):
    monkeypatch.setenv(cache_bound.MAX_SIZE_ENV, "1G")
    monkeypatch.setattr(cache_bound, "WALK_EVERY", 3)
    _derived(tmp_path, "a", 10, used_days_ago=0)
    walks = []
    monkeypatch.setattr(cache_bound, "enforce", lambda folder, limit, keep=(): walks.append(keep))
    for name in "bcd":
        _derived(tmp_path, name, 10, used_days_ago=0)
    assert walks == []
    _derived(tmp_path, "e", 10, used_days_ago=0)
    assert walks == [(f"{cache.DERIVED_PREFIX}e",)]


def test_what_is_in_use_is_never_evicted(tmp_path, monkeypatch):
    """Entries used within the grace time (another process may be linking an object it has just checked) and the
    entry just stored stay, even past the bound."""
    monkeypatch.setenv(cache_bound.MAX_SIZE_ENV, "0")
    recent = _derived(tmp_path, "recent", 10_000, used_days_ago=cache_bound.GRACE / 2 / DAY)
    old = _derived(tmp_path, "old", 10_000, used_days_ago=1)
    monkeypatch.setenv(cache_bound.MAX_SIZE_ENV, "5k")
    cache_bound._max_size.cache_clear()
    new = _derived(tmp_path, "new", 10_000, used_days_ago=0)
    assert recent.exists() and new.exists() and not old.exists()
    result = cache_bound.evict(cache_bound.scan(tmp_path), 1, keep=(f"{cache.DERIVED_PREFIX}new",))
    assert not recent.exists() and new.exists() and result.left == new.stat().st_size
    walks = []
    monkeypatch.setattr(cache_bound, "scan", lambda folder: walks.append(folder))
    _derived(tmp_path, "small", 10, used_days_ago=0)
    assert walks == []  # still past the bound, but not by what an eviction frees since the last walk: no walk


def test_temporaries_in_progress_are_spared_and_stale_ones_removed(tmp_path, monkeypatch):
    monkeypatch.setenv(cache_bound.MAX_SIZE_ENV, "1k")
    building, stale = tmp_path / ".build-abc", tmp_path / ".prebuild-def"
    for folder in (building, stale):
        folder.mkdir()
        (folder / "unit.o").write_bytes(b"x" * 5000)
    writing = tmp_path / f".{cache.DERIVED_PREFIX}x.json.123.tmp"
    writing.write_text("half")
    _age([stale], cache_bound.STALE_TEMPORARY * 2 / DAY)
    found = cache_bound.scan(tmp_path)
    assert sorted(p.name for p, _, _ in found.temporaries) == sorted([building.name, stale.name, writing.name])
    assert found.entries == () and found.size == 0
    assert cache_bound.remove_stale_temporaries(found) == 1
    assert building.exists() and writing.exists() and not stale.exists()


def test_one_process_walks_at_a_time(tmp_path, monkeypatch):
    fcntl = pytest.importorskip("fcntl")
    _derived(tmp_path, "a", 10_000, used_days_ago=1)
    fd = os.open(tmp_path, os.O_RDONLY)  # another process's lock (flock: per open file, so this process's too)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        assert cache_bound.enforce(tmp_path, 1) is None
    finally:
        os.close(fd)
    assert cache_bound.enforce(tmp_path, 1).removed == 1


_STORING = """
import sys
from pathlib import Path
from mbs.runtime import cache, cache_bound
cache_bound.GRACE = 0.0  # (every entry may go: the races below happen at once, not after ten minutes)
folder, me, damaged, read = Path(sys.argv[1]), sys.argv[2], [], 0
for i in range(120):
    cache.write_derived(folder / f"{cache.DERIVED_PREFIX}{me}{i:04d}.json", {"blob": "x" * 3000}, me)
    for j in range(max(0, i - 10), i + 1):
        for who in "ab":
            payload, why = cache.read_derived(folder / f"{cache.DERIVED_PREFIX}{who}{j:04d}.json")
            read += payload is not None
            if payload is None and "No such file" not in why:
                damaged.append(why)
print(read, damaged)
"""


def test_two_processes_storing_and_reading_at_once_never_see_half_an_entry(tmp_path):
    """Two processes store past a small bound and read each other's entries while both evict: a read finds an
    entry whole or not at all (writes and removals are atomic), and neither process fails."""
    env = dict(os.environ, MBS_CACHE_MAX_SIZE="100k")
    procs = [subprocess.Popen([sys.executable, "-c", _STORING, str(tmp_path), who], env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for who in "ab"]
    for proc in procs:
        out, err = proc.communicate(timeout=300)
        assert proc.returncode == 0, err
        read, damaged = out.split(" ", 1)
        assert damaged.strip() == "[]" and int(read) > 120
    found = cache_bound.scan(tmp_path)
    # (a store appended to the ledger while the other process replaced it is not counted: an entry or two over)
    assert found.size <= 110_000 and len(found.entries) >= 20 and found.temporaries == ()


def test_an_eviction_error_never_fails_the_store(tmp_path, monkeypatch, caplog):
    monkeypatch.setenv(cache_bound.MAX_SIZE_ENV, "1k")

    def broken(folder):
        raise PermissionError(13, "Permission denied")
    monkeypatch.setattr(cache_bound, "scan", broken)
    with caplog.at_level(logging.DEBUG, "mbs.cache"):
        path = _derived(tmp_path, "a", 10_000, used_days_ago=0)
    assert path.exists() and "the size bound was not enforced" in caplog.text
    caplog.clear()
    with caplog.at_level(logging.INFO, "mbs.cache"):
        _derived(tmp_path, "b", 10, used_days_ago=0)
    assert caplog.text == ""  # (debug only)


# ---------------------------------------------------------------------------------------------- mbs cache
def test_mbs_cache_reports_size_kinds_and_bound(tmp_path, monkeypatch, capsys):
    from mbs.cli import main
    monkeypatch.setenv("MBS_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv(cache_bound.MAX_SIZE_ENV, "0")
    _library(tmp_path, "one", 20_000, used_days_ago=3)
    _library(tmp_path, "two", 20_000, used_days_ago=1)
    _derived(tmp_path, "eq", 5_000, used_days_ago=2)
    (tmp_path / ".build-xyz").mkdir()
    monkeypatch.setenv(cache_bound.MAX_SIZE_ENV, "2G")
    assert main(["cache"]) == 0
    out = capsys.readouterr().out
    assert f"build cache {tmp_path}" in out
    assert "compiled models             2" in out and "derived equations           1" in out
    assert "builds in progress          1" in out
    assert "total                       3" in out and "of 2.0 GB ($MBS_CACHE_MAX_SIZE=2G)" in out
    assert "least recently used 3.0 d ago" in out
    assert main(["cache", "list"]) == 0
    assert "used    3.0 d ago  fake one" in capsys.readouterr().out


def test_mbs_cache_clean_max_size_removes_the_least_recently_used(tmp_path, monkeypatch, capsys):
    from mbs.cli import main
    monkeypatch.setenv("MBS_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv(cache_bound.MAX_SIZE_ENV, "0")
    one = _library(tmp_path, "one", 20_000, used_days_ago=3)
    two = _library(tmp_path, "two", 20_000, used_days_ago=0)  # used just now: an explicit clean spares nothing
    eq = _derived(tmp_path, "eq", 5_000, used_days_ago=2)
    assert main(["cache", "clean", "--max-size", "25k"]) == 0
    assert "removed 2 least recently used entries" in capsys.readouterr().out
    assert not any(p.exists() for p in one) and not eq.exists() and all(p.exists() for p in two)
    assert main(["cache", "clean", "--max-size", "1k"]) == 0
    assert not any(p.exists() for p in two)


@pytest.mark.parametrize("args, message", [(["--max-size", "lots"], "error: --max-size: 'lots' is not a size"),
                                           (["--max-size", "0"], "error: --max-size must be more than 0"),
                                           (["--max-size", "1G", "--older-than", "2"], "not allowed with")])
def test_a_bad_clean_is_a_clear_error(tmp_path, args, message):
    run = subprocess.run([sys.executable, "-m", "mbs", "cache", "--dir", str(tmp_path), "clean", *args],
                         capture_output=True, text=True)
    assert run.returncode != 0 and message in run.stderr and "Traceback" not in run.stderr


def test_a_bad_variable_is_a_warning_of_mbs_cache(tmp_path):
    env = dict(os.environ, MBS_CACHE_DIR=str(tmp_path), MBS_CACHE_MAX_SIZE="5 apples")
    run = subprocess.run([sys.executable, "-m", "mbs", "cache"], capture_output=True, text=True, env=env)
    assert run.returncode == 0 and "Traceback" not in run.stderr
    assert "mbs: warning: MBS_CACHE_MAX_SIZE: '5 apples' is not a size" in run.stderr
    assert "of 1.0 GB (the default)" in run.stdout


# ---------------------------------------------------------------------------------------------- end to end
def test_a_warm_run_keeps_its_entries_and_the_unused_go(tmp_path, monkeypatch):
    """A real model: its warm run touches what it uses (validated model, derivations, library), so a store past
    the bound removes the older entries it did not use (the runtime object, an old fake) and keeps those."""
    model = ROOT / "library" / "examples" / "pendulum.mbs"
    env = dict(os.environ, MBS_CACHE_DIR=str(tmp_path), MBS_CACHE_MAX_SIZE="1G")
    simulate = [sys.executable, "-m", "mbs", "-v", "simulate", str(model), "--t-end", "0.05"]
    assert subprocess.run(simulate, env=env, capture_output=True).returncode == 0
    _age([p for p in tmp_path.iterdir() if p.is_file()], 2)
    stale = _library(tmp_path, "stale", 30_000, used_days_ago=1)
    kinds = {e.name: e.kind for e in cache_bound.scan(tmp_path).entries}
    assert sorted(kinds.values()) == ["build", "build", "derivation", "derivation", "model", "object"]
    warm = subprocess.run(simulate, env=env, capture_output=True, text=True)
    assert warm.returncode == 0 and "cache hit" in warm.stderr
    used = {e.name for e in cache_bound.scan(tmp_path).entries if time.time() - e.used < 600}
    assert {kinds[name] for name in used} == {"build", "derivation", "model"} and len(used) == 4
    bound = sum(e.size for e in cache_bound.scan(tmp_path).entries if e.name in used) + 2000
    monkeypatch.setenv(cache_bound.MAX_SIZE_ENV, f"{bound}B")
    _derived(tmp_path, "new", 100, used_days_ago=0)  # a store: the ledger is past the bound
    left = {e.name for e in cache_bound.scan(tmp_path).entries}
    assert left == used | {f"{cache.DERIVED_PREFIX}new"} and not any(p.exists() for p in stale)
    again = subprocess.run(simulate, env=env, capture_output=True, text=True)
    assert again.returncode == 0 and "C build of pendulum: cache hit" in again.stderr
