"""`rtdemo trace-pixel`: the model's ray tree for a pixel as JSON (docs/commands/trace-pixel.md)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from helpers import SCENES, render_demo, run

CLASSIC = SCENES / "classic.json"
W, H = 160, 120


def _trace(rtdemo: str, *args: str) -> dict[str, Any]:
    proc = run([rtdemo, "trace-pixel", str(CLASSIC), *args, "--width", str(W), "--height", str(H)])
    assert proc.returncode == 0, proc.stderr
    out: dict[str, Any] = json.loads(proc.stdout)
    return out


def test_tree_colour_is_the_rendered_pixel(rtdemo: str, tmp_path: Path) -> None:
    model = ("--mode", "classic", "--mistake", "fresnel_constant")
    image = render_demo(rtdemo, CLASSIC, tmp_path / "r.exr", "-q", *model, size=(W, H))
    for x, y in ((80, 60), (0, 0), (20, 110), (120, 70)):
        got = _trace(rtdemo, str(x), str(y), *model, "--json")
        assert got["format"] == "rtdemo-ray-tree/1" and (got["x"], got["y"]) == (x, y)
        assert got["mistakes"] == ["fresnel_constant"] and got["mode"] == "classic"
        want = image.rgb[y, x]
        assert np.array_equal(np.float32(got["color"]), want), (x, y)
        assert np.array_equal(np.float32(got["tree"]["color"]), want), (x, y)


def test_tree_of_the_glass_centre(rtdemo: str) -> None:
    got = _trace(rtdemo, "80", "60", "--mode", "classic")
    tree = got["tree"]
    assert tree["kind"] == "camera" and tree["hit"]["name"] == "glass"
    assert tree["event"] == "specular" and tree["fresnel"] is not None
    kinds = {c["kind"] for c in tree["children"]}
    assert kinds == {"reflection", "refraction"}
    inner = next(c for c in tree["children"] if c["kind"] == "refraction")
    assert inner["hit"]["inside"] is True and inner["depth"] == 1
    assert got["path"] & 2048 and got["path"] & 64  # GLASS_HIT, GLASS_LEAVE


def test_many_pixels_from_a_file(rtdemo: str, tmp_path: Path) -> None:
    listing = tmp_path / "pixels.txt"
    listing.write_text("# x y\n0 0\n80 60\n\n159 119\n")
    got = _trace(rtdemo, "--pixels", str(listing), "--mode", "paper")
    assert [(p["x"], p["y"]) for p in got["pixels"]] == [(0, 0), (80, 60), (159, 119)]
    assert got["pixels"][0]["path"] == 1 and got["pixels"][0]["tree"]["hit"] is None
    assert got["width"] == W and "tree" not in got


def test_errors_name_the_pixel_or_the_line(rtdemo: str, tmp_path: Path) -> None:
    base = [rtdemo, "trace-pixel", str(CLASSIC)]
    outside = run([*base, "640", "10"])
    assert (
        outside.returncode == 2 and "pixel (640, 10) is outside the 640x480 image" in outside.stderr
    )
    bad = tmp_path / "bad.txt"
    bad.write_text("1 2\n3\n")
    proc = run([*base, "--pixels", str(bad)])
    assert proc.returncode == 2 and f"{bad}:2: expected 'X Y'" in proc.stderr
    assert run([*base, "1"]).returncode == 2
    assert run([*base, "1", "2", "--spp", "4"]).returncode == 2
    helped = run([rtdemo, "trace-pixel", "--help"])
    assert helped.returncode == 0 and "--pixels FILE" in helped.stdout
