"""`rtval reference --snapshot SPP:OUT`: the image after SPP samples of a longer render is the
image of the same command with --spp SPP, bit for bit, whether it is taken on the way (one
sample per launch, as at the report's sizes) or rendered apart (several per launch)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers import SCENES

from compare.cli.main import main
from compare.judge.images import read_image
from mitsuba_ref import reference
from mitsuba_ref.reference import ReferenceImage, ReferenceSettings, render_reference
from scene_model.scene import load_scene

pytestmark = pytest.mark.slow


def _same(a: ReferenceImage, b: ReferenceImage) -> None:
    assert np.array_equal(a.rgb, b.rgb)
    assert (a.variance is None) == (b.variance is None)
    if a.variance is not None:
        assert np.array_equal(a.variance, b.variance)
    assert a.aovs.keys() == b.aovs.keys()
    assert all(np.array_equal(a.aovs[k], b.aovs[k]) for k in a.aovs)
    assert {**a.header, "rtval.render_seconds": ""} == {**b.header, "rtval.render_seconds": ""}


@pytest.mark.parametrize("wavefront", [24 * 18, reference.MAX_WAVEFRONT])
@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_snapshots_are_the_renders_of_their_spp(
    monkeypatch: Any, wavefront: int, integrator: str
) -> None:
    monkeypatch.setattr(reference, "MAX_WAVEFRONT", wavefront)  # 24x18: one sample per launch
    scene = load_scene(SCENES / "lit.json")
    settings = ReferenceSettings(integrator=integrator, spp=6, size=(24, 18), light="point")
    taken: list[ReferenceImage] = []
    full = render_reference(
        scene, dataclasses.replace(settings, snapshots=(1, 4)), None, taken.append
    )
    assert sorted(t.spp_done for t in taken) == [1, 4]
    for image in taken:
        _same(image, render_reference(scene, dataclasses.replace(settings, spp=image.spp_done)))
    _same(full, render_reference(scene, settings))


def test_snapshot_options_are_checked_before_any_work(tmp_path: Path, capsys: Any) -> None:
    scene, out = str(SCENES / "lit.json"), str(tmp_path / "r.exr")
    for bad, code, text in (
        (["--spp", "4", "--snapshot", "0:a.exr"], 64, "expected SPP:OUT.exr"),
        (["--spp", "4", "--snapshot", "4"], 64, "expected SPP:OUT.exr"),
        (["--spp", "4", "--snapshot", f"4:{tmp_path / 'a.exr'}"], 64, "snapshots must be 1 .. spp - 1"),
        (["--spp", "4", "--snapshot", f"2:{out}"], 64, "--snapshot names the same file as -o"),
        (["--spp", "4", "--time-budget", "9", "--snapshot", f"2:{tmp_path / 'a.exr'}"], 64, "time budget"),
        (["--spp", "4", "--light", "point", "--centre-rays", "--snapshot", f"2:{tmp_path / 'a.exr'}"], 64, "one pass"),
    ):  # fmt: skip
        assert _exit_code(["reference", scene, "-o", out, "--size", "8x6", *bad]) == code
        assert text in capsys.readouterr().err, bad
    assert list(tmp_path.iterdir()) == []


def _exit_code(argv: list[str]) -> object:
    try:
        return main(argv)
    except SystemExit as e:  # argparse
        return e.code


def test_a_batch_reports_each_snapshot(tmp_path: Path, capsys: Any) -> None:
    small = tmp_path / "p2.exr"
    job = [str(SCENES / "lit.json"), "-o", str(tmp_path / "p6.exr"), "--integrator", "path",
           "--spp", "6", "--size", "12x9", "--snapshot", f"2:{small}"]  # fmt: skip
    (tmp_path / "jobs.json").write_text(json.dumps({"jobs": [job]}))
    assert main(["reference", "--batch", str(tmp_path / "jobs.json")]) == 0
    events = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    snap = [e for e in events if e["event"] == "snapshot"]
    assert [(e["job"], e["spp"], e["output"]) for e in snap] == [(0, 2, str(small))]
    assert events[-1]["event"] == "done"
    assert read_image(small).header["rtval.spp"] == "2"
