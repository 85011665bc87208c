"""`rtval cache`: the shared render cache's size, cap and counts; clearing or trimming it."""

from __future__ import annotations

import argparse


def _human(n: int) -> str:
    size = float(n)
    for unit in ("B", "KB", "MB", "GB"):
        if size < 1000 or unit == "GB":
            return f"{size:.0f} {unit}" if unit == "B" else f"{size:.1f} {unit}"
        size /= 1000
    return f"{size:.1f} GB"


def _size_arg(text: str) -> int:
    from compare.render.cache import parse_size

    try:
        return parse_size(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def run_cache(args: argparse.Namespace) -> int:
    from compare.render.cache import RenderCache

    cache = RenderCache(args.cache)
    cache.check_root()
    if args.clear:
        files, size = cache.clear()
        print(f"{cache.root}: removed {files} files, {_human(size)}")
        return 0
    if args.max_size is not None:
        cache.set_max_bytes(args.max_size)
        entries, freed = cache.evict()
        print(
            f"{cache.root}: size cap set to {_human(args.max_size)}; evicted {entries} entries, {_human(freed)}"
        )
    files, size = cache.size()
    renders = sum(p.suffix == ".exr" for p in cache.entry_files())
    s = cache.stats()
    print(
        f"{cache.root}: {renders} renders, {files} files, {_human(size)} "
        f"(cap {_human(cache.max_bytes())})\n"
        f"  since created: {s['hits']} hits, {s['misses']} misses, {s['evictions']} evictions, "
        f"{s['discarded']} damaged entries discarded"
    )
    return 0


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    from compare.cli.common import add_cache_argument
    from compare.render.cache import DEFAULT_MAX_BYTES, GRACE_SECONDS, MAX_SIZE_ENV

    p = sub.add_parser(
        "cache",
        help="show the shared render cache's size, cap and counts, or clear it",
        description="The render cache that report, grade, stress and check share: renders "
        "keyed by their command, the scene's bytes and the renderer, plus metrics and "
        "figures derived from them. Prints its folder, size, size cap and its counts of hits, "
        "misses and evictions (the default), or removes every entry with --clear (renders in "
        "progress in other processes are left alone). The cap is kept by evicting the least "
        f"recently used entries after each render, never one used in the last {GRACE_SECONDS} s; "
        f"it is ${MAX_SIZE_ENV}, else the one set with --max-size, else "
        f"{DEFAULT_MAX_BYTES // 10**9} GB.",
    )
    g = p.add_mutually_exclusive_group()
    g.add_argument("--size", action="store_true", help="print the folder and its size (default)")
    g.add_argument("--clear", action="store_true", help="remove every cached render and result")
    g.add_argument(
        "--max-size",
        type=_size_arg,
        metavar="SIZE",
        help="set the cache's size cap (e.g. 2GB, 500MB) and evict down to it now",
    )
    add_cache_argument(p)
    p.set_defaults(func=run_cache)
