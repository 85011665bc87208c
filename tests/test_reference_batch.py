"""`rtval reference --batch`: several references in one process give the images their own
commands give, report progress and each render as JSON lines, and fail with the job named."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import SCENES, run

from compare.judge.images import read_image

pytestmark = pytest.mark.slow
RTVAL = str(Path(sys.executable).with_name("rtval"))
SCENE = str(SCENES / "classic.json")
PAPER = str(SCENES / "paper.json")  # no light: the background is its only emitter
WHITTED = ["--integrator", "whitted", "--light", "point", "--centre-rays", "--size", "24x18"]
PATH = ["--integrator", "path", "--light", "point", "--spp", "3", "--seed", "5", "--size", "24x18"]


def test_batch_renders_what_single_commands_render(tmp_path: Path) -> None:
    jobs = {"jobs": [[SCENE, "-o", str(tmp_path / "w.exr"), *WHITTED],
                     [SCENE, "-o", str(tmp_path / "p.exr"), *PATH],
                     [PAPER, "-o", str(tmp_path / "l.exr"), *PATH]]}  # fmt: skip
    (tmp_path / "jobs.json").write_text(json.dumps(jobs))
    proc = run([RTVAL, "reference", "--batch", str(tmp_path / "jobs.json")])
    assert proc.returncode == 0, proc.stderr
    events = [json.loads(line) for line in proc.stdout.splitlines()]
    done = [e for e in events if e["event"] == "done"]
    assert [e["job"] for e in done] == [0, 1, 2] and all(e["seconds"] > 0 for e in done)
    progress = [e for e in events if e["event"] == "progress" and e["job"] == 1]
    assert progress and progress[-1]["done"] == progress[-1]["total"] == 3
    for name, scene, options in (("w", SCENE, WHITTED), ("p", SCENE, PATH), ("l", PAPER, PATH)):
        alone = tmp_path / f"{name}-alone.exr"
        single = run([RTVAL, "reference", scene, "-o", str(alone), *options])
        assert single.returncode == 0, single.stderr
        a, b = read_image(tmp_path / f"{name}.exr"), read_image(alone)
        # Same seed, same samples, same image, up to the order in which the JIT's parallel
        # scatter-adds sum a pixel's lobes (float rounding; one test run differed).
        assert np.allclose(a.rgb, b.rgb, rtol=1e-5, atol=1e-6), name
        assert set(a.aovs) == set(b.aovs)


def test_batch_errors_name_the_file_or_the_job(tmp_path: Path) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text('{"jobs": [["a", 1]]}')
    proc = run([RTVAL, "reference", "--batch", str(bad)])
    assert proc.returncode == 64 and "bad.json: jobs[0]" in proc.stderr
    proc = run([RTVAL, "reference", "--batch", str(tmp_path / "missing.json")])
    assert proc.returncode == 4 and "missing.json" in proc.stderr
    proc = run([RTVAL, "reference", SCENE, "--batch", str(bad)])
    assert proc.returncode == 64 and "--batch takes its scenes" in proc.stderr
    jobs = tmp_path / "jobs.json"
    jobs.write_text(json.dumps({"jobs": [[SCENE, "-o", str(tmp_path / "x.exr"), "--spp", "0"]]}))
    proc = run([RTVAL, "reference", "--batch", str(jobs)])
    assert proc.returncode == 1
    assert json.loads(proc.stdout.splitlines()[-1]) == {
        "event": "error",
        "job": 0,
        "message": f"bad arguments: {SCENE} -o {tmp_path / 'x.exr'} --spp 0",
    }
