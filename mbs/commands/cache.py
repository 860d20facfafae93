"""cache: list, clean and verify the build cache of compiled models and derived equations."""

from __future__ import annotations

import sys
import time


class Cache:
    help = ("the build cache of compiled models, derived equations and validated model files: list entries, clean "
            "them (all or older than N days), verify them")

    @staticmethod
    def arguments(p):
        sub = p.add_subparsers(dest="action", metavar="ACTION", required=True)
        sub.add_parser("list", help="every cached model and derivation: size, age, the model it came from")
        clean = sub.add_parser("clean", help="delete cached models (all of them, or those older than --older-than)")
        clean.add_argument("--older-than", type=float, metavar="DAYS", help="only entries built more than DAYS ago")
        verify = sub.add_parser("verify", help="check every entry against its build record; exit 1 if one is "
                                               "damaged")
        verify.add_argument("--remove", action="store_true", help="delete damaged entries (they are rebuilt on "
                                                                  "next use anyway)")
        p.add_argument("--dir", metavar="DIR", help="the cache folder (default: $MBS_CACHE_DIR, else "
                                                    "~/.cache/baukasten)")

    @staticmethod
    def run(args) -> int:
        from pathlib import Path

        from mbs.runtime import build
        folder = Path(args.dir).expanduser() if args.dir else build.default_cache_dir()
        return {"list": _list, "clean": _clean, "verify": _verify}[args.action](folder, args)


def _size(n: int) -> str:
    for unit in ("B", "kB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return f"{n} B"


def _age(seconds: float) -> str:
    for unit, length in (("d", 86400), ("h", 3600), ("min", 60)):
        if seconds >= length:
            return f"{seconds / length:.1f} {unit}"
    return f"{max(seconds, 0):.0f} s"


def _list(folder, args) -> int:
    from mbs.runtime import cache
    entries = cache.entries(folder)
    now = time.time()
    for e in entries:
        kind = {"derivation": "  (derived equations)", "object": "  (compiled unit)",
                "model": "  (validated model)"}.get(e.kind, "")
        print(f"{e.name}  {_size(e.size):>9}  {_age(now - e.built):>8} old  {e.model}{kind}")
    total = sum(e.size for e in entries)
    print(f"{len(entries)} entr{'y' if len(entries) == 1 else 'ies'}, {_size(total)} in {folder}")
    return 0


def _clean(folder, args) -> int:
    from mbs.language.diagnostics import Diagnostic, MbsError
    from mbs.runtime import cache
    if args.older_than is not None and not args.older_than >= 0:
        raise MbsError([Diagnostic("error", f"--older-than must be a number of days >= 0, got {args.older_than}",
                                   None)])
    now = time.time()
    removed, freed = 0, 0
    for e in cache.entries(folder):
        if args.older_than is None or now - e.built > args.older_than * 86400:
            try:
                freed += cache.remove(e)
            except OSError as exc:
                raise MbsError([Diagnostic("error", f"cannot remove {e.name} from {folder}: {exc.strerror}",
                                           None)]) from None
            removed += 1
    print(f"removed {removed} entr{'y' if removed == 1 else 'ies'}, {_size(freed)} freed in {folder}")
    return 0


def _verify(folder, args) -> int:
    from mbs.runtime import cache
    entries = cache.entries(folder)
    damaged = 0
    for e in entries:
        why = cache.entry_problem(e)
        if why is None:
            continue
        damaged += 1
        action = ""
        if args.remove:
            cache.remove(e)
            action = "; removed"
        print(f"{e.name} ({e.model}): damaged: {why}{action}", file=sys.stderr)
    print(f"{len(entries)} entr{'y' if len(entries) == 1 else 'ies'} verified, {damaged} damaged")
    return 1 if damaged else 0
