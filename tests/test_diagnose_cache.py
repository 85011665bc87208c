"""Diagnose's candidates are render-cache entries like every other render: a plain model's
candidate is the entry `grade` and `report` use, a second search reads what the first made,
and nothing is left outside the cache (no private temporary folder)."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import sys
from pathlib import Path

import pytest
from helpers import SCENES, diagnosed, render_demo, run

from compare.diagnose import flip as diagnose_flip
from compare.diagnose.candidate import Candidate
from compare.diagnose.renderer import CandidateRenderer, forget_recent
from compare.diagnose.search import DiagnoseOptions, diagnose
from compare.judge.images import Image
from compare.judge.target_model import parse_model
from compare.render import jobs
from compare.render.cache import RenderCache
from compare.render.jobs import set_key
from compare.render.models import model_job
from scene_model.scene import load_scene

RTVAL = str(Path(sys.executable).with_name("rtval"))
CLASSIC = SCENES / "classic.json"
W, H = 16, 12


def test_candidates_are_entries_of_the_render_cache(tmp_path: Path) -> None:
    cache = RenderCache(tmp_path / "c")
    forget_recent()  # renders another test read in this process would come from memory
    classic = Candidate.of_mode("classic")
    asked = [classic, classic.turned((1e-4, 0.0)), classic.with_mistake("no_offset", True)]
    with CandidateRenderer(CLASSIC, W, H, cache=cache) as render:
        first = [render(c).rgb for c in asked]
    assert (render.rendered, render.cache_hits) == (3, 0)
    # The plain model's candidate is the model's own render: one entry for both.
    key = set_key(model_job(parse_model("classic"), CLASSIC, (W, H)))
    assert cache.info(key) is not None
    with CandidateRenderer(CLASSIC, W, H, cache=cache) as again:
        second = [again(c).rgb for c in asked]  # this process read them: from memory
    assert (again.rendered, again.cache_hits, again.memory_hits) == (0, 3, 3)
    forget_recent()
    with CandidateRenderer(CLASSIC, W, H, cache=cache) as third:
        from_disk = [third(c).rgb for c in asked]
    assert (third.rendered, third.cache_hits, third.memory_hits) == (0, 3, 0)
    for a, b, d in zip(first, second, from_disk, strict=True):
        assert (a == b).all() and (a == d).all()
    assert not list(cache.tmp_dir.iterdir())  # nothing half-made left behind
    stats = cache.stats()
    assert stats["misses"] >= 3 and stats["hits"] >= 3


def test_a_passing_render_is_read_and_dropped_unless_it_was_slow(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """passing(): the render a search scores once is made into the cache's tmp/, read, and
    removed, with nothing stored; asked for again as a render to keep, it is made again and
    stored, the same pixels. A passing render that took PASSING_KEEP_SECONDS is stored."""
    cache = RenderCache(tmp_path / "c")
    forget_recent()
    cand = Candidate.of_mode("classic").with_mistake("no_offset", True)
    with CandidateRenderer(CLASSIC, W, H, cache=cache) as render:
        once = render.passing(cand).rgb
        key = set_key(render.job(cand))
        assert cache.info(key) is None and not list(cache.tmp_dir.iterdir())
        assert (render.rendered, render.cache_hits) == (1, 0)
        forget_recent()
        kept = render(cand).rgb  # not stored: made again, and stored this time
        assert (render.rendered, render.cache_hits) == (2, 0) and cache.info(key) is not None
        forget_recent()
        assert (render.passing(cand).rgb == once).all()  # now from the cache
        assert (render.rendered, render.cache_hits, render.memory_hits) == (2, 1, 0)
    assert (once == kept).all()
    slow = RenderCache(tmp_path / "slow")
    monkeypatch.setattr(jobs, "PASSING_KEEP_SECONDS", 0.0)
    forget_recent()
    with CandidateRenderer(CLASSIC, W, H, cache=slow) as render:
        assert (render.passing(cand).rgb == once).all()
        assert slow.info(set_key(render.job(cand))) is not None
        assert not list(slow.tmp_dir.iterdir())


def test_a_passing_render_whose_entry_cannot_be_read_is_made_again(tmp_path: Path) -> None:
    """An entry whose EXR has the sha256 its sidecar records but is no image: passing()
    renders the candidate again (and stores it) instead of failing the search."""
    cache = RenderCache(tmp_path / "c")
    forget_recent()
    cand = Candidate.of_mode("classic").with_mistake("no_offset", True)
    with CandidateRenderer(CLASSIC, W, H, cache=cache) as render:
        good = render(cand).rgb
        key = set_key(render.job(cand))
        exr = cache.exr(key)
        exr.write_bytes(b"not an EXR")
        sidecar = exr.with_suffix(".json")
        facts = json.loads(sidecar.read_text())
        facts["sha256"] = hashlib.sha256(b"not an EXR").hexdigest()
        sidecar.write_text(json.dumps(facts))
        forget_recent()
        assert (render.passing(cand).rgb == good).all()
    assert exr.read_bytes() != b"not an EXR" and cache.info(key) is not None


def test_a_search_keeps_the_codes_of_the_renders_it_drops(tmp_path: Path, rtdemo: str) -> None:
    """A diagnosis stores the renders it reads again (its starts, its result, the renders
    its exact matches are made of) and the codes of the candidates it scores; those only
    scored leave no render in the cache, and a search of another image of the same program
    renders nothing."""
    image = render_demo(rtdemo, CLASSIC, tmp_path / "q2.ppm", "-q", "--mode", "classic",
                        "--quirk", "Q2", size=(W, H))  # fmt: skip
    cache = RenderCache(tmp_path / "c")
    forget_recent()
    with CandidateRenderer(CLASSIC, W, H, cache=cache) as render:
        first = diagnose(image, load_scene(CLASSIC), render)
        stored = {n for n, c in render.seen.items() if cache.info(set_key(render.job(c)))}
    assert first.result == "classic+Q2" and "classic" in stored
    dropped = set(render.seen) - stored
    assert len(dropped) > 10 and len(list(cache.derived_dir.glob("diagnose-codes-*"))) > 10
    twin = dataclasses.replace(image, rgb=image.rgb.copy())
    twin.rgb[0, 0] = 1.0 - twin.rgb[0, 0]  # another image: searched again, not recalled
    misses = cache.stats()["misses"]
    again, _ = diagnosed(twin, CLASSIC, (W, H), cache)
    assert again["result"] == first.result and cache.stats()["misses"] == misses


def test_only_plain_models_keep_their_aovs_and_a_switched_start_is_rendered_with_them(
    tmp_path: Path,
) -> None:
    """A switched candidate's entry holds R, G, B alone (the search judges the colour); a
    search begun from one renders it again with the AOVs its effect masks come from, and
    finds what a search from the plain mode finds."""
    cache = RenderCache(tmp_path / "c")
    forget_recent()
    classic = Candidate.of_mode("classic")
    shadowless = classic.with_effect("shadows", False)
    with CandidateRenderer(CLASSIC, W, H, cache=cache) as render:
        for plain in (classic, classic.with_quirk(2, True)):  # classic+Q2 is a model too
            assert sorted(render(plain).aovs) == ["depth", "id"]
        assert render(shadowless).aovs == {} and render(classic.turned((1e-4, 0.0))).aovs == {}
        assert sorted(render.with_aovs(shadowless).aovs) == ["depth", "id"]
        assert (render.with_aovs(shadowless).rgb == render(shadowless).rgb).all()
        image = Image(rgb=render(shadowless).rgb, encoding="float")
    scene = load_scene(CLASSIC)
    forget_recent()
    with CandidateRenderer(CLASSIC, W, H, cache=tmp_path / "d") as render:
        switched = diagnose(image, scene, render, DiagnoseOptions(start=shadowless))
    assert switched.result == "classic --no-shadows"
    with CandidateRenderer(CLASSIC, W, H, cache=tmp_path / "e") as render:
        assert (
            diagnose(image, scene, render, DiagnoseOptions(start=classic)).result == switched.result
        )


def test_rtval_diagnose_renders_nothing_the_cache_has(tmp_path: Path, rtdemo: str) -> None:
    image = tmp_path / "q2.exr"
    render_demo(rtdemo, CLASSIC, image, "-q", "--mode", "classic", "--quirk", "Q2", size=(W, H))
    cache = tmp_path / "c"
    cmd = [RTVAL, "diagnose", str(image), "--scene", str(CLASSIC), "--cache", str(cache), "-q"]
    first = run(cmd)
    assert first.returncode == 0, first.stderr
    misses = RenderCache(cache).stats()["misses"]
    assert misses > 0
    second = run(cmd)
    assert second.returncode == 0 and second.stdout == first.stdout
    assert RenderCache(cache).stats()["misses"] == misses  # every candidate read, none made


def test_a_second_diagnosis_of_an_image_reads_its_flip_numbers(
    tmp_path: Path, rtdemo: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    image = render_demo(rtdemo, CLASSIC, tmp_path / "q2.exr", "-q", "--mode", "classic",
                        "--quirk", "Q2", size=(W, H))  # fmt: skip
    cache = RenderCache(tmp_path / "c")

    def once() -> dict[str, object]:
        return diagnosed(image, CLASSIC, (W, H), cache)[0]

    first = once()
    assert list(cache.derived_dir.glob("diagnose-flip-*.json"))
    for kept in cache.derived_dir.glob("diagnosis-*.json"):
        kept.unlink()  # searched again, but its FLIP numbers read

    def no_flip(*_a: object) -> None:
        raise AssertionError("FLIP computed again")

    monkeypatch.setattr(diagnose_flip.Flips, "_map", no_flip)
    assert once() == first


def test_an_image_diagnosed_before_is_not_searched_again(tmp_path: Path, rtdemo: str) -> None:
    image = render_demo(rtdemo, CLASSIC, tmp_path / "nb.exr", "-q", "--mode", "classic",
                        "--mistake", "black_background", size=(W, H))  # fmt: skip
    cache = RenderCache(tmp_path / "c")

    def once(im: Image) -> tuple[dict[str, object], int]:
        d, seen = diagnosed(im, CLASSIC, (W, H), cache)
        return d, len(seen)

    first, asked = once(image)
    assert asked > 10 and list(cache.derived_dir.glob("diagnosis-*.json"))
    again, asked_again = once(image)
    assert again == first and asked_again == 0  # nothing rendered, nothing read
    other = dataclasses.replace(image, rgb=image.rgb.copy())
    other.rgb[0, 0, 0] += 0.25  # another image: searched
    _, asked_other = once(other)
    assert asked_other > 10
