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


def test_an_entry_is_hashed_again_only_once_its_stamp_changes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An entry whose inode, size and times are those its sidecar recorded is the file that
    was hashed when stored; a touched one (same bytes) is hashed and kept."""
    from compare.render import cache as cache_module

    cache = RenderCache(tmp_path)
    job = _render(cache, "classic")
    hashed: list[Path] = []
    real = cache_module.sha256_file

    def counting(path: Path) -> str:
        hashed.append(path)
        return real(path)

    monkeypatch.setattr(cache_module, "sha256_file", counting)
    cache_module._HASHES.clear()  # as a fresh process
    assert cache.info(job.cache_key) is not None and hashed == []
    os.utime(job.exr(cache))  # the same bytes, another time: hashed, still whole
    assert cache.info(job.cache_key) is not None and hashed == [job.exr(cache)]


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


def test_planted_scene_copies_are_checked_not_followed(tmp_path: Path) -> None:
    """The red-team pass: the perturbed renders' scene copies in derived/ replaced by links to
    a black-background scene made the spread cover the image, and black_background PASSED."""
    import json

    from compare.judge.target_model import parse_model
    from compare.render.models import render_offsets

    cache = RenderCache(tmp_path / "c")
    model, size = parse_model("classic"), (32, 24)
    first = [read_image(p).rgb for p in render_offsets(model, SCENES / "classic.json", size, cache)]
    evil = json.loads((SCENES / "classic.json").read_text())
    evil["background"] = [0, 0, 0]
    (tmp_path / "evil.json").write_text(json.dumps(evil))
    copies = sorted(cache.derived_dir.glob("scene-*-perturbed.json"))
    assert len(copies) == 10
    for c in copies[:5]:
        c.unlink()
        c.symlink_to(tmp_path / "evil.json")
    for c in copies[5:]:
        c.write_text(json.dumps(evil))  # a plain file with other bytes
    for c in cache.renders.glob("*"):
        c.unlink()  # and nothing cached, so they are rendered from the copies again
    again = [read_image(p).rgb for p in render_offsets(model, SCENES / "classic.json", size, cache)]
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))
    assert not any(c.is_symlink() for c in copies)


def test_a_scene_copy_another_thread_writes_meanwhile_is_kept(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two candidates of one search share a scene copy; one thread found it missing while the
    other renamed it in, then took it for a planted non-file and removed it: the render
    failed with "cannot read the scene file". The other thread's write is simulated here,
    right after the first look."""
    cache = RenderCache(tmp_path / "c")
    target = cache.derived("scene-x-candidate.json")
    real_lstat = os.lstat

    def written_meanwhile(path, *args, **kwargs):  # type: ignore[no-untyped-def]
        if Path(path) == target and not target.exists():
            try:
                return real_lstat(path, *args, **kwargs)
            finally:
                target.write_text("{}")
        return real_lstat(path, *args, **kwargs)

    monkeypatch.setattr(os, "lstat", written_meanwhile)
    assert cache.derived("scene-x-candidate.json") == target
    assert target.read_text() == "{}"


@pytest.mark.parametrize("plant", ["fifo", "link", "lock-link"])
def test_the_counts_never_stop_a_verdict(
    tmp_path: Path, plant: str, capfd: pytest.CaptureFixture[str]
) -> None:
    cache = RenderCache(tmp_path / "c")
    _render(cache, "classic")
    stats = cache.root / ("stats.json" if plant != "lock-link" else ".stats.lock")
    stats.unlink(missing_ok=True)
    if plant == "fifo":
        os.mkfifo(stats)
    else:
        stats.symlink_to(tmp_path / "elsewhere")
    job = _render(cache, "physical")  # a miss: counted, or not, but rendered
    assert job.exr(cache).is_file() and not (tmp_path / "elsewhere").exists()
    assert "counts not kept" in capfd.readouterr().err


def test_cache_command_looks_through_no_link_and_checks_its_size_setting(tmp_path: Path) -> None:
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "victim.exr").write_bytes(b"x")
    root = tmp_path / "c"
    root.mkdir()
    (root / "renders").symlink_to(outside)
    proc = run([RTVAL, "cache", "--cache", str(root)])
    assert proc.returncode == 4 and "not a folder" in proc.stderr, proc.stdout
    env = {**os.environ, "RTVAL_CACHE_MAX_SIZE": "lots"}
    image = tmp_path / "black.ppm"
    image.write_bytes(b"P6\n32 24\n255\n" + bytes(32 * 24 * 3))
    scene = str(SCENES / "classic.json")
    cmd = [RTVAL, "compare", str(image), "--against", "classic", "--scene", scene]
    proc = run([*cmd, "--cache", str(tmp_path / "d")], env=env)
    assert proc.returncode == 64 and "RTVAL_CACHE_MAX_SIZE" in proc.stderr, proc.stderr
    assert not (tmp_path / "d" / "renders").exists()  # refused before any render
