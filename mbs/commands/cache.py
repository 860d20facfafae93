"""cache: how big the build cache is and what bounds it; list, clean and verify its entries."""

from __future__ import annotations

import sys
import time


class Cache:
    help = ("the build cache of compiled models, derived equations and validated model files: its size and bound "
            "(no ACTION), list entries, clean them (all, older than N days, or down to a size), verify them")

    @staticmethod
    def arguments(p):
        sub = p.add_subparsers(dest="action", metavar="ACTION")
        sub.add_parser("info", help="the cache's size, entries of each kind and its size bound (also with no ACTION)")
        sub.add_parser("list", help="every cached model and derivation: size, age, last use, the model it came from")
        clean = sub.add_parser("clean", help="delete cached models (all of them, those older than --older-than, or "
                                             "the least recently used down to --max-size)")
        which = clean.add_mutually_exclusive_group()
        which.add_argument("--older-than", type=float, metavar="DAYS", help="only entries built more than DAYS ago")
        which.add_argument("--max-size", metavar="SIZE", help="the least recently used entries until the rest take at "
                                                              "most SIZE (500M, 2G: powers of 1000; 1GiB: of 1024)")
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
        action = {None: _info, "info": _info, "list": _list, "clean": _clean, "verify": _verify}[args.action]
        return action(folder, args)


def _size(n: float) -> str:
    from mbs.runtime.cache_bound import format_size
    return format_size(n)


#: What `mbs cache` calls each kind of entry (runtime/cache.py kind_of).
KINDS = {"build": "compiled models", "object": "compiled units", "derivation": "derived equations",
         "model": "validated model files"}


def _info(folder, args) -> int:
    from mbs.runtime import cache_bound
    found = cache_bound.scan(folder)
    print(f"build cache {folder}")
    for kind, label in KINDS.items():
        of_kind = [e for e in found.entries if e.kind == kind]
        print(f"  {label:<22} {len(of_kind):>6}  {_size(sum(e.size for e in of_kind)):>9}")
    if found.temporaries:
        print(f"  {'builds in progress':<22} {len(found.temporaries):>6}  (or left by killed processes; removed "
              f"after {cache_bound.STALE_TEMPORARY / 3600:.0f} h)")
    limit = cache_bound.max_size()
    bound = f"of {_size(limit)} ({cache_bound.max_size_origin()})" if limit else \
        f"(no bound: {cache_bound.max_size_origin()})"
    print(f"  {'total':<22} {len(found.entries):>6}  {_size(found.size):>9} {bound}")
    if found.entries:
        print(f"  least recently used {_age(time.time() - found.entries[0].used)} ago" +
              ("; past the bound the least recently used entries are removed" if limit else ""))
    return 0


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
        print(f"{e.name}  {_size(e.size):>9}  {_age(now - e.built):>8} old  used {_age(now - e.used):>8} ago  "
              f"{e.model}{kind}")
    total = sum(e.size for e in entries)
    print(f"{len(entries)} entr{'y' if len(entries) == 1 else 'ies'}, {_size(total)} in {folder}")
    return 0


def _clean(folder, args) -> int:
    from mbs.language.diagnostics import Diagnostic, MbsError
    from mbs.runtime import cache, cache_bound
    if args.older_than is not None and not args.older_than >= 0:
        raise MbsError([Diagnostic("error", f"--older-than must be a number of days >= 0, got {args.older_than}",
                                   None)])
    if args.max_size is not None:
        return _clean_to(folder, args.max_size)
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
    cache_bound.forget_ledger(folder)
    print(f"removed {removed} entr{'y' if removed == 1 else 'ies'}, {_size(freed)} freed in {folder}")
    return 0


def _clean_to(folder, text: str) -> int:
    """clean --max-size: the least recently used entries until the rest fit (none spared but temporaries)."""
    from mbs.language.diagnostics import Diagnostic, MbsError
    from mbs.runtime import cache_bound
    try:
        limit = cache_bound.parse_size(text)
    except ValueError as exc:
        raise MbsError([Diagnostic("error", f"--max-size: {exc}", None)]) from None
    if limit <= 0:
        raise MbsError([Diagnostic("error", "--max-size must be more than 0 (`mbs cache clean` removes every "
                                            "entry)", None)])
    result = cache_bound.evict(cache_bound.scan(folder), limit)
    cache_bound.forget_ledger(folder)
    print(f"removed {result.removed} least recently used entr{'y' if result.removed == 1 else 'ies'}, "
          f"{_size(result.freed)} freed; {_size(result.left)} left in {folder}")
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
