"""The render cache trusts nothing it finds and stays bounded: a replaced or truncated render
is discarded and made again, links are never followed (neither to read nor to delete), an
empty --cache is refused, a cache others can write is named in a warning, and the least
recently used entries go first once it passes its cap. rtdemo renders at 32x24 only."""

from __future__ import annotations

import io
import os
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from helpers import SCENES, run

from compare.judge.images import read_image
from compare.render.cache import GRACE_SECONDS, CacheError, RenderCache, parse_size
from compare.render.jobs import RenderJob, run_jobs
from compare.render.progress import Progress

RTVAL = str(Path(sys.executable).with_name("rtval"))


def _job(mode: str) -> RenderJob:
    args = ["render", "{scene}", "-o", "{out}", "-q", "--mode", mode, "--width", "32"]
    return RenderJob(
        f"m-{mode}",
        mode,
        "rtdemo",
        [*args, "--height", "24"],
        "demo",
        scene=str(SCENES / "classic.json"),
    )


def _render(cache: RenderCache, mode: str) -> RenderJob:
    job = _job(mode)
    run_jobs([job], cache, progress=Progress(io.StringIO(), tty=False))
    return job


def test_a_replaced_render_is_discarded_and_made_again(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    """The poisoning of the hostile-input pass: a classic+Q2 render planted under the classic
    key made a correct student fail. Its sha256 no longer matches the sidecar's."""
    cache = RenderCache(tmp_path)
    right = _render(cache, "classic")
    wrong = _render(cache, "paper")
    truth = read_image(right.exr(cache)).rgb
    right.exr(cache).write_bytes(wrong.exr(cache).read_bytes())
    again = _render(cache, "classic")
    assert not again.cached  # rendered anew, not served
    assert np.array_equal(read_image(again.exr(cache)).rgb, truth)
    assert "does not match the sha256" in capfd.readouterr().err
    assert cache.stats()["discarded"] == 1


def test_a_truncated_or_linked_entry_is_rendered_again(tmp_path: Path) -> None:
    cache = RenderCache(tmp_path)
    job = _render(cache, "classic")
    exr = job.exr(cache)
    exr.write_bytes(exr.read_bytes()[:100])
    assert cache.info(job.cache_key) is None and not exr.exists()
    job = _render(cache, "classic")
    outside = tmp_path / "outside.exr"
    outside.write_bytes(exr.read_bytes())
    exr.unlink()
    exr.symlink_to(outside)  # same bytes, but a link: never followed
    assert cache.info(job.cache_key) is None
    assert outside.is_file() and not os.path.lexists(exr)


def test_clear_never_follows_a_planted_link(tmp_path: Path) -> None:
    victim = tmp_path / "victim"
    victim.mkdir()
    (victim / "precious.txt").write_text("keep me")
    root = tmp_path / "cache"
    root.mkdir()
    (root / "renders").symlink_to(victim)
    proc = run([RTVAL, "cache", "--clear", "--cache", str(root)])
    assert proc.returncode == 4 and "never follows links" in proc.stderr, proc.stderr
    assert (victim / "precious.txt").read_text() == "keep me"
    with pytest.raises(CacheError, match="not a folder"):
        RenderCache(root).tmp_path("k")


def test_an_empty_cache_path_or_a_device_is_refused() -> None:
    proc = run([RTVAL, "cache", "--cache", ""])
    assert proc.returncode == 4 and "empty path names no folder" in proc.stderr
    proc = run([RTVAL, "cache", "--cache", "/dev/zero"])  # exited 0, "0 renders"
    assert proc.returncode == 4 and "is a character device, not a folder" in proc.stderr


def test_a_cache_others_can_write_is_named(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    root = tmp_path / "shared"
    root.mkdir()
    root.chmod(0o777)
    RenderCache(root).tmp_path("k")
    assert f"render cache {root} is writable by every user" in capfd.readouterr().err


def _entry(cache: RenderCache, key: str, size: int, age: float) -> None:
    cache.tmp_path(key)  # creates the folders
    for p in (cache.exr(key), cache.renders / f"{key}.json"):
        p.write_bytes(b"x" * (size // 2))
        os.utime(p, (time.time() - age, time.time() - age))


def test_eviction_takes_the_least_recently_used_first_and_spares_recent_ones(
    tmp_path: Path,
) -> None:
    cache = RenderCache(tmp_path)
    _entry(cache, "oldest", 1000, 3 * GRACE_SECONDS)
    _entry(cache, "older", 1000, 2 * GRACE_SECONDS)
    _entry(cache, "recent", 1000, 1)
    assert cache.evict(max_bytes=1500) == (2, 2000)  # "recent" alone stays
    assert cache.exr("recent").is_file() and not cache.exr("older").exists()
    _entry(cache, "new", 1000, 2)
    assert cache.evict(max_bytes=0) == (0, 0)  # both in use within the grace period
    assert cache.stats()["evictions"] == 2


def test_rtval_cache_reports_counts_and_sets_a_cap(tmp_path: Path) -> None:
    cache = RenderCache(tmp_path)
    _render(cache, "classic")
    _render(cache, "classic")
    proc = run([RTVAL, "cache", "--cache", str(tmp_path)])
    assert proc.returncode == 0 and "1 hits, 1 misses, 0 evictions" in proc.stdout, proc.stdout
    proc = run([RTVAL, "cache", "--cache", str(tmp_path), "--max-size", "2GB"])
    assert proc.returncode == 0 and "(cap 2.0 GB)" in proc.stdout, proc.stdout
    assert RenderCache(tmp_path).max_bytes() == 2 * 10**9
    assert run([RTVAL, "cache", "--cache", str(tmp_path), "--max-size", "lots"]).returncode == 64


def test_size_texts() -> None:
    assert parse_size("500MB") == 500 * 10**6 and parse_size("1e9") == 10**9
    assert parse_size("2 gb") == 2 * 10**9 and parse_size("0") == 0
    for bad in ("-1GB", "nan", "1e40", "2 GiB"):
        with pytest.raises(ValueError, match="expected a size"):
            parse_size(bad)
