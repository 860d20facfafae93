"""bench/rhs_instructions.py's counts for this checkout and for another git revision of the whole tree (its compiler,
runtime and language: a change of the derivation, which rhs_instructions.py --baseline, the run-time C files of
another revision, does not cover), in the same run, with the ratios.

    python bench/rhs_instructions_revision.py REV [--scene bump_5] [--calls 200]

REV (a commit or branch) is extracted with `git archive` into a temporary folder, whose folders are linked under an
importable `mbs` package there (pyproject.toml's package-dir) and imported ahead of this checkout (PYTHONPATH, the
child started outside the repository), with a build cache of its own. Both children run rhs_instructions.py's
CHILD under callgrind: the Iltis's `rhs` (projected), `loop_rhs` (no projection) and the open chain's `rhs`, per
call. The revision's library/iltis/vehicle.mbs is this checkout's (the same model for both).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import rhs_instructions as counts  # noqa: E402

#: The repository's package folders (pyproject.toml's package-dir), linked under the revision's mbs/.
PACKAGES = ("base", "language", "compiler", "runtime", "library")


def revision_environment(rev: str, folder: Path) -> dict:
    """The environment in which a child imports `mbs` from the repository at `rev` (extracted into folder)."""
    repo = Path(__file__).resolve().parent.parent
    source = folder / "source"
    source.mkdir(parents=True)
    archive = subprocess.run(["git", "-C", str(repo), "archive", rev], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(source)], input=archive, check=True)
    package = folder / "importable" / "mbs"
    package.parent.mkdir()
    subprocess.run(["cp", "-r", str(source / "mbs"), str(package)], check=True)
    for name in PACKAGES:
        (package / name).symlink_to(source / name)
    return dict(os.environ, PYTHONPATH=str(package.parent), MBS_CACHE_DIR=str(folder / "cache"))


def count(scene: str, calls: int, warm: int, workdir: Path, env: dict) -> dict:
    """Instructions per call of rhs_instructions.FUNCTIONS with the child in `env`, started in workdir (outside the
    repository, whose mbs/ folder would be imported first)."""
    bench = str(Path(__file__).resolve().parent)
    subprocess.run([sys.executable, "-c", counts.CHILD, bench, str(counts.MODEL), scene, "0", "0"], check=True,
                   env=env, cwd=workdir)  # compile outside valgrind
    saved, here = dict(os.environ), os.getcwd()
    os.environ.clear()
    os.environ.update(env)
    os.chdir(workdir)
    try:
        dumps = counts.run_child(scene, calls, warm, workdir)
    finally:
        os.chdir(here)
        os.environ.clear()
        os.environ.update(saved)
    return {name: counts.instructions(dump) / calls for name, dump in zip(counts.FUNCTIONS, dumps[1::2])}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rev", help="the git revision to compare with (e.g. main)")
    parser.add_argument("--scene", default="bump_5")
    parser.add_argument("--calls", type=int, default=200)
    parser.add_argument("--warm", type=int, default=5)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "current").mkdir()
        ours = count(args.scene, args.calls, args.warm, Path(tmp) / "current", dict(os.environ))
        theirs_folder = Path(tmp) / "revision"
        env = revision_environment(args.rev, theirs_folder)
        (theirs_folder / "work").mkdir()
        theirs = count(args.scene, args.calls, args.warm, theirs_folder / "work", env)
    print(f"Iltis ({args.scene}): instructions per call inside C (callgrind, {args.calls} calls each), this checkout "
          f"against {args.rev} in the same run")
    for name, label in (("rhs", "constrained rhs (projected)"), ("loop_rhs", "constrained rhs (no projection)"),
                        ("chain rhs", "open chain rhs")):
        print(f"  {label:32s} {ours[name]:10.0f}   {theirs[name]:10.0f} at {args.rev}   {ours[name] / theirs[name]:.3f} x")
    print(f"  loop_rhs / the chain's rhs: {ours['loop_rhs'] / ours['chain rhs']:.2f} here, "
          f"{theirs['loop_rhs'] / theirs['chain rhs']:.2f} at {args.rev}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
