"""The build cache verifies what it loads, and `mbs cache` lists, cleans and verifies it."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from mbs.cli import main
from mbs.runtime import build, cache
from mbs.runtime.errors import BuildError

FIXTURES = Path(__file__).parent / "fixtures"


def _fixture() -> Path:
    return sorted(FIXTURES.glob("*.c"))[0]


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """One fresh build of the fixture (compiled once for this file)."""
    return build.build_file(_fixture(), cache_dir=tmp_path_factory.mktemp("one-build"))


def _copy_of(built, folder: Path):
    """The cached entry copied into `folder`, as the BuildResult a build there would give."""
    import shutil
    for path in built.path.parent.glob(built.module_name + "*"):
        shutil.copy(path, folder)
    return build.BuildResult(folder / built.path.name, built.module_name, built.key, True, "")


def test_a_fresh_build_records_size_and_hash(built):
    result = built
    record = cache.read_record(result.path)
    assert record["size"] == result.path.stat().st_size
    assert record["sha256"] == cache.sha256(result.path)
    assert cache.problem(result.path) is None


def test_a_truncated_module_is_rebuilt_with_a_note_and_never_loaded(built, tmp_path, caplog):
    """The audit's case: a cached .so cut short on disk crashed the next run with a bus error."""
    first = _copy_of(built, tmp_path)
    assert build.build_file(_fixture(), cache_dir=tmp_path).cached  # the copy is a cache hit
    size = first.path.stat().st_size
    with open(first.path, "r+b") as f:
        f.truncate(size // 3)
    assert "size is" in cache.problem(first.path)
    again = build.build_file(_fixture(), cache_dir=tmp_path)
    assert not again.cached and again.path == first.path
    assert again.path.stat().st_size == size and cache.problem(again.path) is None
    assert "is not loaded" in caplog.text and "rebuilding" in caplog.text


def test_a_truncated_module_in_a_fresh_process_runs_the_model(tmp_path):
    """End to end in a new interpreter (a damaged module loaded there would kill it with SIGBUS)."""
    import mbs
    model = Path(__file__).resolve().parents[2] / "library" / "examples" / "pendulum.mbs"
    # built here but not loaded here (a module mapped into this process must not be cut short under it)
    build.build(mbs.load(model).generate("swing").c_source, cache_dir=tmp_path)
    for module in tmp_path.glob(f"*{cache.EXT_SUFFIX}"):
        with open(module, "r+b") as f:
            f.truncate(4096)
    env = dict(os.environ, MBS_CACHE_DIR=str(tmp_path))
    run = subprocess.run([sys.executable, "-m", "mbs", "simulate", str(model), "--t-end", "0.05"], env=env,
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert "rebuilding it" in run.stderr


def test_a_module_without_record_or_with_other_content_is_not_trusted(built, tmp_path):
    result = _copy_of(built, tmp_path)
    data = bytearray(result.path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    result.path.write_bytes(bytes(data))
    assert "SHA-256" in cache.problem(result.path)
    cache.record_path(result.path).unlink()
    assert cache.problem(result.path) == "it has no build record"


def test_a_cache_path_that_is_a_file_is_a_clear_error(tmp_path):
    blocker = tmp_path / "cache"
    blocker.write_text("not a folder")
    with pytest.raises(BuildError, match="a file, not a folder"):
        build.build_file(_fixture(), cache_dir=blocker)


def test_an_unwritable_cache_is_a_clear_error(tmp_path, monkeypatch):
    """A read-only folder (as root the permission bits do not stop us, so the refusal is simulated)."""
    def refuse(*args, **kwargs):
        raise PermissionError(13, "Permission denied")
    monkeypatch.setattr(build.tempfile, "mkdtemp", refuse)
    with pytest.raises(BuildError, match="cannot be used .Permission denied.: set MBS_CACHE_DIR"):
        build.build_file(_fixture(), cache_dir=tmp_path / "ro")


def test_mbs_cache_lists_verifies_and_cleans(built, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("MBS_CACHE_DIR", str(tmp_path))
    result = _copy_of(built, tmp_path)
    assert main(["cache", "list"]) == 0
    out = capsys.readouterr().out
    assert result.module_name in out and "1 entry" in out
    assert main(["cache", "verify"]) == 0
    with open(result.path, "r+b") as f:
        f.truncate(100)
    assert main(["cache", "verify"]) == 1
    assert "damaged: its size is 100 bytes" in capsys.readouterr().err
    assert main(["cache", "clean", "--older-than", "1"]) == 0  # built just now: kept
    assert result.path.exists()
    assert main(["cache", "clean"]) == 0
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("distribution", ["sympy", "lark", "numpy"])
def test_installed_versions_are_the_metadata_s(distribution):
    """The cheap look-up of a version (the dist-info folder's name, for the caches' keys) agrees with
    importlib.metadata; a distribution that is not installed has the version '?'."""
    import importlib.metadata
    assert cache.installed_version(distribution) == importlib.metadata.version(distribution)
    assert cache.installed_version("no_such_distribution_here") == "?"


def test_keys_keep_their_parts_apart():
    """digest labels each part with its length: moving text from one part to the next gives another key."""
    assert cache.digest(("a", "xy"), ("b", "z")) != cache.digest(("a", "x"), ("b", "yz"))
    assert cache.digest(("a", "x")) == cache.digest(("a", "x"))
