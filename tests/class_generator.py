"""A synthetic class for testing and benchmarking `rtval grade`: submissions of known kinds
made from a reference render and from the demo. Returns the expected verdict per student."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from helpers import render_demo

from compare.judge.images import read_image, write_exr
from compare.judge.png import write_png

# kind -> expected gradebook status (error/missing rows are "fail" with a reason)
KINDS = {
    "copy": "pass",
    "physical16": "pass",
    "noise_small": "pass",
    "noise_large": "fail",
    "biased": "fail",
    "wrong_size": "fail",
    "corrupt": "fail",
    "missing": "fail",
    "no_shadows": "fail",
    "no_refraction": "fail",
    "nan": "fail",
}


def make_class(
    reference_exr: Path,
    scene_file: Path,
    rtdemo: str,
    folder: Path,
    *,
    per_kind: int = 3,
    size: tuple[int, int] = (160, 120),
    seed: int = 7,
) -> dict[str, tuple[str, str]]:
    """Writes per_kind submissions of every kind into `folder`; returns id -> (kind, expected)."""
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    ref = read_image(reference_exr).rgb
    scene = scene_file.stem
    demo: dict[str, np.ndarray] = {}
    for kind, args in (
        ("physical16", ["--spp", "16"]),
        ("no_shadows", ["--no-shadows", "--spp", "16"]),
        ("no_refraction", ["--no-refraction", "--spp", "16"]),
    ):
        out = folder.parent / f"_{kind}.exr"
        demo[kind] = render_demo(
            rtdemo, scene_file, out, "--mode", "physical", "-q", *args, size=size
        ).rgb
    expected = {}
    for kind, status in KINDS.items():
        for i in range(per_kind):
            sid = f"{kind}_{i}"
            expected[sid] = (kind, status)
            if kind == "copy":
                write_exr(folder / f"{sid}.exr", ref)
            elif kind in demo:
                write_png(folder / f"{sid}.png", demo[kind]) if i % 2 else write_exr(
                    folder / f"{sid}.exr", demo[kind]
                )
            elif kind == "noise_small":
                write_exr(
                    folder / f"{sid}.exr",
                    (ref + rng.normal(0, 0.002, ref.shape)).astype(np.float32),
                )
            elif kind == "noise_large":
                write_exr(
                    folder / f"{sid}.exr",
                    np.clip(ref + rng.normal(0, 0.3, ref.shape), 0, None).astype(np.float32),
                )
            elif kind == "biased":
                write_exr(folder / f"{sid}.exr", (ref * 1.6 + 0.05).astype(np.float32))
            elif kind == "wrong_size":
                write_png(folder / f"{sid}.png", ref[: size[1] // 2, : size[0] // 2])
            elif kind == "corrupt":
                (folder / f"{sid}.ppm").write_bytes(b"P6\n160 120\n255\n" + bytes(100))
            elif kind == "missing":
                (folder / sid).mkdir(exist_ok=True)
                write_png(folder / sid / "other_scene.png", ref)
            elif kind == "nan":
                bad = ref.copy()
                bad[::7, ::5] = np.nan
                write_exr(folder / f"{sid}.exr", bad)
            if kind in ("copy", "physical16") and i == per_kind - 1:  # one as a folder per scene
                src = next(folder.glob(f"{sid}.*"))
                (folder / f"{sid}_dir").mkdir(exist_ok=True)
                src.rename(folder / f"{sid}_dir" / f"{scene}{src.suffix}")
                expected[f"{sid}_dir"] = expected.pop(sid)
    return expected
