"""`rtval cache`: the size of the shared render cache, or clearing it."""

from __future__ import annotations

import argparse

from compare.cli.common import add_cache_argument


def _human(n: int) -> str:
    size = float(n)
    for unit in ("B", "KB", "MB", "GB"):
        if size < 1000 or unit == "GB":
            return f"{size:.0f} {unit}" if unit == "B" else f"{size:.1f} {unit}"
        size /= 1000
    return f"{size:.1f} GB"


def run_cache(args: argparse.Namespace) -> int:
    from compare.render.cache import RenderCache

    cache = RenderCache(args.cache)
    if args.clear:
        files, size = cache.clear()
        print(f"{cache.root}: removed {files} files, {_human(size)}")
        return 0
    files, size = cache.size()
    renders = len(list(cache.renders.glob("*.exr"))) if cache.renders.is_dir() else 0
    print(f"{cache.root}: {renders} renders, {files} files, {_human(size)}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "cache",
        help="show the size of the shared render cache, or clear it",
        description="The render cache that report, grade, stress and check share: renders "
        "keyed by their command, the scene's bytes and the renderer, plus metrics and "
        "figures derived from them. Prints its folder and size (the default), or removes "
        "every entry with --clear (renders in progress in other processes are left alone).",
    )
    g = p.add_mutually_exclusive_group()
    g.add_argument("--size", action="store_true", help="print the folder and its size (default)")
    g.add_argument("--clear", action="store_true", help="remove every cached render and result")
    add_cache_argument(p)
    p.set_defaults(func=run_cache)
