"""Digests of the generated texts of every library and test model, to check that a change of the derivation
leaves them byte for byte as they were.

    python bench/derive_texts.py now.json                      # this checkout's code
    git archive main | tar -x -C /tmp/base                     # a copy of the code before the change
    python bench/derive_texts.py before.json --code /tmp/base  # ... its code, the same model files
    python bench/derive_texts.py --compare before.json now.json

Per model file (library/, tests/ but their error and note fixtures; and the 40-link chain of bench/chain.py):
the SHA-256 of the C and NumPy texts of the model's own outputs and of its first three scenes, and of the
model's equations with the Jacobian, with the dynamics functions and with the parameter Jacobian (an error's
message where one is refused). The model files are always this checkout's (their path is written into the C).
"""

from __future__ import annotations

import argparse
import hashlib
import importlib.util
import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = {"base": "base", "language": "language", "compiler": "compiler", "runtime": "runtime",
            "library": "library"}  # mbs.<name> -> directory (pyproject.toml's package-dir)


def _use_code_of(tree: Path) -> None:
    """Import mbs and its subpackages from `tree` (a checkout laid out as this one) instead of this checkout."""
    def package(name: str, path: Path):
        spec = importlib.util.spec_from_file_location(name, path / "__init__.py",
                                                      submodule_search_locations=[str(path)])
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
        return module
    mbs = package("mbs", tree / "mbs")
    for name, directory in PACKAGES.items():  # (the model library this checkout's, as the model files)
        setattr(mbs, name, package(f"mbs.{name}", (ROOT if name == "library" else tree) / directory))


def model_files() -> list[Path]:
    tests = [f for f in sorted((ROOT / "tests").rglob("*.mbs")) if not {"errors", "notes"} & set(f.parts)]
    return sorted((ROOT / "library").rglob("*.mbs")) + tests


def digests(only: str | None = None) -> dict[str, str]:
    import mbs
    from mbs.language.diagnostics import MbsError
    sys.path.insert(0, str(ROOT / "bench"))
    from chain import chain_text

    def digest(generated) -> str:
        return hashlib.sha256((generated.c_source + "\n#####\n" + generated.numpy_source).encode()).hexdigest()

    out: dict[str, str] = {}
    for source in [*model_files(), "chain40"]:
        name = source if source == "chain40" else str(source.relative_to(ROOT))
        if only is not None and only not in name:
            continue
        with tempfile.TemporaryDirectory() as cache:
            try:
                system = (mbs.loads(chain_text(40), path="<chain>", cache_dir=cache) if source == "chain40"
                          else mbs.load(source, cache_dir=cache))
            except MbsError as exc:  # (a file of components only)
                out[name] = "error " + str(exc).splitlines()[0]
                continue
            for scene in [None, *(s.name for s in system.model.scenes)][:4]:
                variants = {"": {}}
                if scene is None:
                    variants.update(jac={"jacobian": True}, dyn={"dynamics": True},
                                    pjac={"parameter_jacobian": True})
                for label, options in variants.items():
                    key = f"{name}|{scene}" + (f"|{label}" if label else "")
                    try:
                        out[key] = digest(system.generate(scene, **options))
                    except MbsError as exc:
                        out[key] = "error " + str(exc).splitlines()[0]
                    print(key, out[key][:16], flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", help="JSON file of the digests")
    ap.add_argument("--code", type=Path, help="a checkout whose code derives (default: this one)")
    ap.add_argument("--only", help="only the models whose path contains this")
    ap.add_argument("--compare", nargs=2, metavar=("BEFORE", "NOW"), help="compare two JSON files of digests")
    args = ap.parse_args()
    if args.compare:
        before, now = (json.loads(Path(f).read_text()) for f in args.compare)
        differ = [k for k in before if before[k] != now.get(k)]
        print(f"{len(before)} texts, {len(differ)} differ, {len(set(now) - set(before))} new")
        for k in differ:
            print(f"  differs: {k}")
        sys.exit(1 if differ else 0)
    if args.code is not None:
        _use_code_of(args.code.resolve())
    Path(args.out).write_text(json.dumps(digests(args.only), indent=1, sort_keys=True))


if __name__ == "__main__":
    main()
