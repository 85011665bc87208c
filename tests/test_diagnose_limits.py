"""No candidate may run away: each render of a search has a time limit derived from the
start's own cost (trials.limit_time); a candidate over it is stopped (its process group
killed, jobs.RenderTimeLimit) and skipped, and the diagnosis says so. It also has a ray budget
derived from the starts' rays (trials.limit_rays): rtdemo stops a render past it itself
(--ray-budget, exit 6, jobs.RenderRayBudget), and the candidate is skipped alike."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from helpers import SCENES

from compare.diagnose.candidate import Candidate
from compare.diagnose.renderer import CandidateRenderer
from compare.diagnose.search import DiagnoseOptions, FunctionRenderer, diagnose
from compare.diagnose.trials import RAY_FACTOR, TIME_LIMIT_MAX, TIME_LIMIT_MIN
from compare.judge.images import Image
from compare.judge.target_model import TargetModel
from compare.render.jobs import RenderRayBudget, RenderTimeLimit
from scene_model.scene import load_scene

CLASSIC = SCENES / "classic.json"
# The candidate that once held a class's grading for 13 minutes: a ray tree that doubles at
# every glass bounce.
RUNAWAY = (
    Candidate.of_mode("classic")
    .with_depth(32)
    .with_mistake("no_inside_flip", True)
    .with_mistake("black_background", True)
)


def test_a_runaway_render_is_stopped_at_its_time_limit(tmp_path: Path) -> None:
    with CandidateRenderer(CLASSIC, 640, 480, threads=1, cache=tmp_path) as render:
        render.time_limit = 0.5
        t0 = time.perf_counter()
        with pytest.raises(RenderTimeLimit, match=r"stopped after 0\.5 s \(its time limit\)"):
            render(RUNAWAY)
        assert time.perf_counter() - t0 < 5  # stopped, not waited for (it takes minutes)
        assert render.rendered == 0  # nothing stored for it
        render.time_limit = None
        render(Candidate.of_mode("classic"))  # a plain render still renders
        assert render.cost(Candidate.of_mode("classic")) > 0


@dataclass
class _Slow(FunctionRenderer):
    """The toy scene: background 1, a glass block 0.3 (0.5 with Q2); the start costs 0.1 s
    and any candidate deeper than 20 runs past the limit."""

    def __call__(self, what: TargetModel | Candidate) -> Image:
        c = what if isinstance(what, Candidate) else Candidate.from_model(what)
        if self.time_limit is not None and c.max_depth is not None and c.max_depth > 20:
            raise RenderTimeLimit(f"{c.name} stopped after {self.time_limit:.1f} s")
        return self.render(c)

    def passing(self, what: TargetModel | Candidate) -> Image:
        return self(what)

    def cost(self, what: TargetModel | Candidate) -> float:
        return 0.1


def _toy(what: TargetModel | Candidate) -> Image:
    c = what if isinstance(what, Candidate) else Candidate.from_model(what)
    ids = np.full((32, 32), -1.0, np.float32)
    ids[8:24, 8:24] = 1.0
    rgb = np.ones((32, 32, 3), np.float32)
    rgb[ids == 1] = 0.5 if 2 in c.quirks else 0.3
    return Image(rgb=rgb, aovs={"id": ids, "depth": np.where(ids >= 0, 20.0, 0.0)})


def test_a_candidate_over_the_limit_is_skipped_and_said() -> None:
    rgb = _toy(Candidate.of_mode("classic").with_quirk(2, True)).rgb
    image = Image(rgb=np.floor(rgb * 255) / 255, path="toy.ppm", encoding="linear")
    render = _Slow(_toy)
    start = Candidate.of_mode("classic")
    d = diagnose(image, load_scene(CLASSIC), render, DiagnoseOptions(start=start))
    # 40 x the start's 0.1 s, within the bounds.
    assert render.time_limit == min(TIME_LIMIT_MAX, max(TIME_LIMIT_MIN, 4.0))
    assert d.exact and 2 in d.quirks_present, d.sentences  # the search still finds Q2
    assert d.skipped == ["classic --max-depth 32 (classic --max-depth 32 stopped after 4.0 s)"]
    assert any(s.startswith(f"skipped ({len(d.skipped)} candidates ran past") for s in d.sentences)


class _Uncosted(_Slow):
    """Its renders come from a cache that kept no time for them (a class's second student)."""

    def cost(self, what: TargetModel | Candidate) -> float:
        return 0.0


def test_a_start_of_unknown_cost_still_bounds_every_candidate() -> None:
    # Grading 200 submissions waited minutes on `--max-depth 32 --mistake no_inside_flip`: the
    # starts were read from the cache, their cost unknown, and no limit was set.
    rgb = _toy(Candidate.of_mode("classic").with_quirk(2, True)).rgb
    image = Image(rgb=np.floor(rgb * 255) / 255, path="toy.ppm", encoding="linear")
    render = _Uncosted(_toy)
    diagnose(
        image, load_scene(CLASSIC), render, DiagnoseOptions(start=Candidate.of_mode("classic"))
    )
    assert render.time_limit == TIME_LIMIT_MAX


def test_a_runaway_render_is_stopped_by_its_ray_budget(tmp_path: Path) -> None:
    # No time limit: the test waits for rtdemo, which stops the render itself (without the
    # budget this one traces ~7.5e9 rays at 64x48, a minute on two threads).
    with CandidateRenderer(CLASSIC, 64, 48, threads=2, cache=tmp_path) as render:
        start = Candidate.of_mode("classic")
        render(start)
        rays = render.rays(start)
        assert rays > 0  # read from the start's EXR header
        render.ray_budget = RAY_FACTOR * rays
        before = render.rendered
        with pytest.raises(
            RenderRayBudget, match=rf"stopped: ray budget of {RAY_FACTOR * rays} rays exhausted"
        ):
            render(RUNAWAY)
        assert render.rendered == before  # nothing stored for it
        render(start.with_depth(6))  # a candidate within the budget still renders
        assert 0 < render.rays(start.with_depth(6)) <= RAY_FACTOR * rays


@dataclass
class _Budgeted(FunctionRenderer):
    """The toy scene, except that a candidate deeper than 20 is the issue's runaway (RUNAWAY),
    rendered by rtdemo on classic.json at 64x48 under this renderer's ray budget; the start's
    rays are those of rtdemo's classic render at that size."""

    real: CandidateRenderer | None = None

    def __call__(self, what: TargetModel | Candidate) -> Image:
        c = what if isinstance(what, Candidate) else Candidate.from_model(what)
        if c.max_depth is not None and c.max_depth > 20:
            assert self.real is not None and self.ray_budget is not None, "no ray budget set"
            self.real.ray_budget = self.ray_budget
            return self.real(RUNAWAY)
        return self.render(c)

    def passing(self, what: TargetModel | Candidate) -> Image:
        return self(what)

    def rays(self, what: TargetModel | Candidate) -> int:
        assert self.real is not None
        return self.real.rays(Candidate.of_mode("classic"))


def test_a_candidate_over_its_ray_budget_is_skipped_and_said(tmp_path: Path) -> None:
    rgb = _toy(Candidate.of_mode("classic").with_quirk(2, True)).rgb
    image = Image(rgb=np.floor(rgb * 255) / 255, path="toy.ppm", encoding="linear")
    with CandidateRenderer(CLASSIC, 64, 48, threads=2, cache=tmp_path) as real:
        real(Candidate.of_mode("classic"))
        render = _Budgeted(_toy, real=real)
        start = Candidate.of_mode("classic")
        d = diagnose(image, load_scene(CLASSIC), render, DiagnoseOptions(start=start))
    assert render.ray_budget == RAY_FACTOR * real.rays(start) > 0
    assert d.exact and 2 in d.quirks_present, d.sentences  # the search still finds Q2
    assert len(d.skipped) == 1
    assert d.skipped[0].startswith(f"classic --max-depth 32 ({RUNAWAY.name} stopped: ray budget")
    said = [s for s in d.sentences if s.startswith("skipped (1 candidates ran past")]
    assert said and "ray budget of" in said[0], d.sentences
