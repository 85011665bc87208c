"""The shared render cache: where it lives, what its key holds, concurrent writers,
`rtval cache`, progress lines, and the Pareto front and Mitsuba-to-converged arithmetic the
report builds on it. rtdemo renders at 32x24 only; no Mitsuba here."""

from __future__ import annotations

import io
import json
import shutil
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from helpers import SCENES, run

from compare.judge.convergence import mitsuba_to_converged
from compare.judge.images import Image
from compare.judge.pareto import pareto_front
from compare.render.cache import RenderCache, default_cache_dir, render_key
from compare.render.jobs import RenderJob, run_jobs
from compare.render.progress import Progress

RTVAL = str(Path(sys.executable).with_name("rtval"))


def _demo_job(scene: Path, mode: str = "paper") -> RenderJob:
    args = ["render", "{scene}", "-o", "{out}", "-q", "--mode", mode]
    return RenderJob(
        f"demo-{mode}",
        f"demo {mode}",
        "rtdemo",
        [*args, "--width", "32", "--height", "24"],
        "demo",
        scene=str(scene),
    )


def test_cache_folder_precedence(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("RTVAL_CACHE", str(tmp_path / "chosen"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert default_cache_dir() == tmp_path / "chosen"
    monkeypatch.delenv("RTVAL_CACHE")
    assert default_cache_dir() == tmp_path / "xdg" / "rtval"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/ignored")  # the XDG spec: absolute only
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert default_cache_dir() == tmp_path / "home" / ".cache" / "rtval"


def test_second_run_is_cached_and_the_key_follows_the_content(tmp_path: Path) -> None:
    cache = RenderCache(tmp_path / "cache")
    scene = tmp_path / "a" / "classic.json"
    scene.parent.mkdir()
    shutil.copy(SCENES / "classic.json", scene)
    first = [_demo_job(scene), _demo_job(scene, "physical")]
    run_jobs(first, cache, progress=Progress(io.StringIO(), tty=False))
    assert not any(j.cached for j in first)
    assert all(j.exr(cache).is_file() and len(j.info["sha256"]) == 64 for j in first)
    # The same scene bytes elsewhere: the same renders (paths are not part of the key).
    moved = tmp_path / "b" / "other-name.json"
    moved.parent.mkdir()
    shutil.copy(scene, moved)
    again = [_demo_job(moved), _demo_job(moved, "physical")]
    run_jobs(again, cache, progress=Progress(io.StringIO(), tty=False))
    assert all(j.cached for j in again)
    assert [j.cache_key for j in again] == [j.cache_key for j in first]
    # One byte of the scene changed: rendered again.
    data = json.loads(scene.read_text())
    data["bias"] = 2e-4
    moved.write_text(json.dumps(data))
    changed = [_demo_job(moved)]
    run_jobs(changed, cache, progress=Progress(io.StringIO(), tty=False))
    assert not changed[0].cached and changed[0].cache_key != first[0].cache_key
    assert not list(cache.tmp_dir.iterdir())  # nothing left half-written


def test_rtdemo_environment_is_part_of_the_key(monkeypatch: pytest.MonkeyPatch) -> None:
    """RTDEMO_ISA picks another kernel: its renders are kept apart (a kernel bug must not hide
    behind another kernel's cached render)."""
    args = ["render", "{scene}", "-o", "{out}"]
    monkeypatch.delenv("RTDEMO_ISA", raising=False)
    plain = render_key("rtdemo", args, SCENES / "classic.json")
    monkeypatch.setenv("RTDEMO_ISA", "scalar")
    forced = render_key("rtdemo", args, SCENES / "classic.json")
    assert plain != forced
    assert render_key("rtdemo", [*args, "-q"], SCENES / "classic.json") != forced


def test_the_gl_build_beside_rtdemo_is_part_of_the_key(tmp_path: Path) -> None:
    """--backend gl re-executes as rtdemo-gl: a change to that build alone re-renders."""
    from compare.render.runner import rtdemo_path

    shutil.copy(rtdemo_path(), tmp_path / "rtdemo")
    args = ["render", "{scene}", "-o", "{out}", "--backend", "gl"]
    alone = render_key("rtdemo", args, SCENES / "classic.json", str(tmp_path / "rtdemo"))
    (tmp_path / "rtdemo-gl").write_bytes(b"one GL build")
    first = render_key("rtdemo", args, SCENES / "classic.json", str(tmp_path / "rtdemo"))
    (tmp_path / "rtdemo-gl").write_bytes(b"another GL build")
    second = render_key("rtdemo", args, SCENES / "classic.json", str(tmp_path / "rtdemo"))
    assert len({alone, first, second}) == 3


def _store_many(args: tuple[str, int]) -> str:
    root, n = args
    cache = RenderCache(root)
    for i in range(n):
        tmp = cache.tmp_path("samekey")
        tmp.write_bytes(bytes([i % 7]) * 200_000)
        cache.store("samekey", tmp, {"seconds": 1.0, "writer": i})
    return str(cache.info("samekey"))


def test_two_writers_of_one_key_leave_a_whole_entry(tmp_path: Path) -> None:
    with ProcessPoolExecutor(max_workers=2) as pool:
        list(pool.map(_store_many, [(str(tmp_path), 25)] * 2))
    cache = RenderCache(tmp_path)
    info = cache.info("samekey")
    assert info is not None
    body = cache.exr("samekey").read_bytes()
    assert len(body) == 200_000 and len(set(body)) == 1  # one writer's file, whole
    assert not list(cache.tmp_dir.iterdir()) and not list(cache.renders.glob(".*"))


def test_rtval_cache_size_and_clear(tmp_path: Path) -> None:
    cache_dir = tmp_path / "c"
    jobs = [_demo_job(SCENES / "classic.json")]
    run_jobs(jobs, RenderCache(cache_dir), progress=Progress(io.StringIO(), tty=False))
    size = jobs[0].exr(RenderCache(cache_dir)).stat().st_size
    proc = run([RTVAL, "cache", "--cache", str(cache_dir)])
    assert proc.returncode == 0, proc.stderr
    assert f"{cache_dir}: 1 renders, 2 files" in proc.stdout
    proc = run([RTVAL, "cache", "--clear", "--cache", str(cache_dir)])
    assert proc.returncode == 0 and "removed 2 files" in proc.stdout, proc.stdout
    assert size > 0 and RenderCache(cache_dir).size() == (0, 0)
    assert run([RTVAL, "cache", "--size", "--clear"]).returncode == 64


def test_progress_redraws_on_a_terminal_and_prints_lines_elsewhere() -> None:
    tty, pipe = io.StringIO(), io.StringIO()
    for stream, is_tty in ((tty, True), (pipe, False)):
        p = Progress(stream, tty=is_tty)
        p.update("reference", 8, 32, 2.0)
        p.line("[1/2] reference: 8.0 s")
    assert pipe.getvalue() == "[1/2] reference: 8.0 s\n"
    # 8 of 32 samples in 2 s: 24 more take about 6 s.
    assert "\r" in tty.getvalue() and "8/32 spp" in tty.getvalue() and "~6 s left" in tty.getvalue()
    assert tty.getvalue().endswith("[1/2] reference: 8.0 s\n")


def test_pareto_front() -> None:
    rows = [
        {"key": "a", "seconds": 1.0, "flip": 0.30},
        {"key": "b", "seconds": 2.0, "flip": 0.35},  # slower and worse than a
        {"key": "c", "seconds": 3.0, "flip": 0.10},
        {"key": "d", "seconds": 0.5, "flip": float("nan")},  # unmeasured: left out
        {"key": "e", "seconds": 3.0, "flip": 0.20},  # as slow as c, worse
        {"key": "f", "seconds": 10.0, "flip": 0.01},
    ]
    assert [r["key"] for r in pareto_front(rows, "flip")] == ["a", "c", "f"]


def test_fastest_mitsuba_to_the_converged_error() -> None:
    h, w = 4, 5
    var = np.full((h, w), 0.32, np.float32)  # per-sample variance: stderr sqrt(0.32 / spp)
    target = float(np.sqrt(0.32 / 32))  # the reference's 32 spp
    ref = Image(
        np.full((h, w, 3), 0.5, np.float32),
        aovs={"var.R": var, "var.G": var, "var.B": var},
        header={"rtval.mean_stderr": f"{target:.9g}", "rtval.render_seconds": "40"},
    )

    def img(value: float, seconds: float) -> Image:
        return Image(
            np.full((h, w, 3), value, np.float32), header={"rtval.render_seconds": str(seconds)}
        )

    out = mitsuba_to_converged(
        ref,
        [
            {"key": "ref", "label": "whitted 32 spp", "spp": 32, "image": ref},
            {"key": "w4", "label": "whitted 4 spp", "spp": 4, "image": img(0.5, 5.0)},
            {"key": "w64", "label": "whitted 64 spp", "spp": 64, "image": img(0.5, 30.0)},
            {"key": "path", "label": "path 64 spp", "spp": 64, "image": img(0.7, 3.0)},
        ],
        {"ref", "w4", "w64"},
    )
    by = {r["key"]: r for r in out["configurations"]}
    assert (
        by["w4"]["error"] == pytest.approx(np.sqrt(0.32 / 4), rel=1e-6) and not by["w4"]["reaches"]
    )
    assert by["ref"]["reaches"] and by["w64"]["reaches"]
    assert by["path"]["error"] == pytest.approx(0.2, rel=1e-5) and not by["path"]["reaches"]
    assert out["fastest"]["key"] == "w64"  # 30 s beats the reference's own 40 s
