"""The report's Mitsuba renders that differ only in samples run as one: the fewer-sample
ones are --snapshot's of the largest (compare/render/jobs.py), and each lands in the cache under
its own command's key with the pixels its own command renders."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import SCENES, run

from compare.judge.images import read_image
from compare.render.cache import RenderCache
from compare.render.jobs import RenderJob, _prefix_groups, run_jobs

pytestmark = pytest.mark.slow
RTVAL = str(Path(sys.executable).with_name("rtval"))
SCENE = str(SCENES / "classic.json")
BASE = ["reference", "{scene}", "-o", "{out}", "--integrator", "path", "--size", "24x18"]


def _job(spp: int, *extra: str) -> RenderJob:
    args = [*BASE, "--spp", str(spp), *extra]
    return RenderJob(f"path-{spp}", f"path {spp} spp", "rtval", args, "mitsuba path", spp, SCENE)


def test_jobs_alike_but_for_samples_are_grouped_under_the_largest() -> None:
    jobs = [_job(1), _job(4), _job(2), _job(4, "--seed", "3"), _job(2, "--time-budget", "1")]
    for j in jobs:
        j.cache_key = " ".join(j.args)
    groups = {" ".join(c.args[9:]): sorted(s.key for s in ss) for c, ss in _prefix_groups(jobs)}
    assert groups["4"] == ["path-1", "path-2"]
    assert groups["4 --seed 3"] == []  # another seed is another sequence of samples
    assert (
        groups["2 --time-budget 1"] == []
    )  # a budget stops at a count not known ahead  # a budget stops at a count not known ahead


def test_a_snapshot_is_cached_as_its_own_command_renders(tmp_path: Path) -> None:
    cache = RenderCache(tmp_path / "cache")
    small, large = _job(2), _job(5)
    run_jobs([small, large], cache)
    assert small.info and large.info and 0 < small.seconds <= large.seconds
    alone = tmp_path / "alone.exr"
    proc = run([RTVAL, *small.command(alone)[1:]])
    assert proc.returncode == 0, proc.stderr
    got, want = read_image(small.exr(cache)), read_image(alone)
    np.testing.assert_array_equal(got.rgb, want.rgb)
    assert not np.array_equal(got.rgb, read_image(large.exr(cache)).rgb)
