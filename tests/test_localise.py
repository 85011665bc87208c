"""Where the error lives (compare/diagnose/localise.py): differing pixels grouped by rtdemo's
path-class AOV, and the step of the algorithm the counts point to."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from helpers import SCENES, render_demo
from student_variants import render_variant

from compare.diagnose.localise import PATH_BITS, RECALL_MIN, classes, locate, on_silhouettes
from compare.diagnose.renderer import CandidateRenderer
from compare.diagnose.search import DiagnoseOptions, FunctionRenderer, diagnose
from compare.judge.images import read_image
from compare.judge.target_model import parse_model
from scene_model.scene import load_scene

CLASSIC = SCENES / "classic.json"
W, H = 160, 120


def _paths(rtdemo: str, tmp_path: Path) -> np.ndarray:
    image = render_demo(
        rtdemo, CLASSIC, tmp_path / "p.exr", "-q", "--mode", "classic",
        "--exr-channels", "rgb+path", size=(W, H),
    )  # fmt: skip
    return image.aovs["path"].astype(np.int64)


def test_path_aov_marks_sky_glass_and_glass_shadow(rtdemo: str, tmp_path: Path) -> None:
    paths = _paths(rtdemo, tmp_path)
    assert paths[0, 0] == PATH_BITS["CAMERA_MISS"]  # the top-left corner is sky
    centre = int(paths[H // 2, W // 2])  # the glass sphere's centre
    for bit in ("GLASS_HIT", "GLASS_ENTER", "GLASS_LEAVE", "MIRROR"):
        assert centre & PATH_BITS[bit], bit
    ground_in_glass_shadow = (paths & PATH_BITS["SHADOW_GLASS"]) != 0
    assert ground_in_glass_shadow[H // 2 :].sum() > 100  # the glass's shadow on the ground


def test_differing_pixels_of_one_bit_name_its_step(rtdemo: str, tmp_path: Path) -> None:
    paths = _paths(rtdemo, tmp_path)
    through_glass = (paths & PATH_BITS["SHADOW_GLASS"]) != 0
    found = locate(through_glass, paths)
    assert found is not None and found.step == "shadow through glass"
    assert found.recall == 1.0 and found.precision == 1.0
    assert f"{int(through_glass.sum()):,} of {int(through_glass.sum()):,}" in found.sentence
    sky = paths == PATH_BITS["CAMERA_MISS"]
    sky_found = locate(sky, paths)
    assert sky_found is not None and sky_found.step == "background"
    # A few pixels of another class do not hide the step; their class is listed.
    mixed = through_glass.copy()
    mixed[0, :3] = True  # three sky pixels
    assert (located := locate(mixed, paths)) is not None
    assert located.step == "shadow through glass" and located.recall < 1.0
    assert {c["class"] for c in classes(mixed, paths, top=50)} >= {"CAMERA_MISS"}


def test_a_class_of_which_few_pixels_differ_blames_no_step_as_a_whole(
    rtdemo: str, tmp_path: Path
) -> None:
    """maede97/RayTracer shades with the last sphere a ray hits: a quarter of the pixels
    reflecting the sky differ. Those pixels lie on such paths, but "the background is wrong"
    would make every one of them differ: the sentence says the error lives on them."""
    paths = _paths(rtdemo, tmp_path)
    sky_bounce = (paths & PATH_BITS["SECONDARY_MISS"]) != 0
    some = sky_bounce & (np.arange(W)[None, :] % 4 == 0)
    found = locate(some, paths)
    assert found is not None and found.precision < 0.5, found
    assert "mostly those" in found.sentence and "is wrong" not in found.sentence
    assert "the error lives on such paths, in the " in found.sentence
    # Every such pixel differing, while the background seen directly matches: a bounced
    # ray's background, or the bounce before it (a Fresnel weight written facing^3 was told
    # "the background is wrong" by a red-team program).
    every = locate(sky_bounce, paths)
    assert every is not None and every.step == "background", every
    assert set(every.alternatives) >= {"reflection", "fresnel"}
    assert "is wrong" not in every.sentence
    # With some of the background seen directly differing too (a tenth), it is wrong.
    sky = paths == PATH_BITS["CAMERA_MISS"]
    both = locate(sky_bounce | (sky & (np.arange(W)[None, :] % 10 == 0)), paths)
    assert both is not None and both.sentence.endswith("the background is wrong"), both.sentence


def test_pixels_spread_over_the_image_name_no_step(rtdemo: str, tmp_path: Path) -> None:
    paths = _paths(rtdemo, tmp_path)
    noise = np.random.default_rng(7).random(paths.shape) < 0.2
    found = locate(noise, paths)
    assert found is not None and found.step == "spread over several steps"
    assert found.bits == () and "several steps" in found.sentence
    assert locate(np.zeros_like(noise), paths) is None


def test_synthetic_pair_is_named_only_when_clearly_more_precise() -> None:
    glass = PATH_BITS["GLASS_ENTER"] | PATH_BITS["GLASS_LEAVE"]
    paths = np.full((20, 20), PATH_BITS["DIFFUSE_LIT"], np.int64)
    paths[:10] = glass
    paths[:5, :10] |= PATH_BITS["SHADOW_GLASS"]
    paths[10:15, :10] |= PATH_BITS["SHADOW_GLASS"]
    differing = np.zeros((20, 20), bool)
    differing[:5, :10] = True  # only the glass paths whose shadow ray passes glass
    found = locate(differing, paths)
    assert found is not None and found.bits == ("SHADOW_GLASS", "GLASS_LEAVE")
    assert found.precision == 1.0 and found.recall >= RECALL_MIN


def test_wrong_eta_leaving_nothing_explains_is_localised(tmp_path: Path) -> None:
    """WrongEtaLeaving (1/ior also leaving glass) with the search denied Q2, the switch that
    explains it: the refraction is then unexplained, and the localisation names the step."""
    scene = load_scene(CLASSIC)
    image = read_image(render_variant(scene, "wrong_eta_leaving", W, H, tmp_path / "s.ppm"))
    with CandidateRenderer(CLASSIC, W, H, cache=tmp_path / "cache") as r:
        no_q2 = tuple(q for q in r.search_quirks if q != 2)
        render = FunctionRenderer(r, r.turns, r.grows, no_q2, paths=r.path_classes)
        d = diagnose(image, scene, render, DiagnoseOptions(start=parse_model("classic")))
    out = d.as_dict()
    assert "refraction" in d.unexplained
    top = out["localisation"][0]
    assert top["step"] == "refraction leaving" and top["recall"] >= RECALL_MIN
    assert "leaves glass" in top["sentence"]
    where = {e["effect"]: e for e in out["unexplained_where"]}
    assert where["refraction"]["step"] == "refraction leaving"
    assert (
        sum(c["differing"] for c in where["refraction"]["classes"])
        <= where["refraction"]["differing"]
    )
    again = type(d).from_record(d.record())  # the memo keeps it
    assert again.as_dict()["localisation"] == out["localisation"]
    assert any(s.startswith("where the error lives: ") and "leaves glass" in s for s in d.sentences)


def test_differing_pixels_on_the_silhouettes_point_to_camera_or_intersection() -> None:
    # A disc's rim (the edges effect's pixels) differs, and only it: the spheres are drawn a
    # little elsewhere. Differing pixels inside the disc too are no silhouette matter.
    yy, xx = np.mgrid[:40, :40]
    r = np.hypot(yy - 20, xx - 20)
    edges = (r > 9) & (r < 11)
    rim = edges & (xx > 20)
    found = on_silhouettes(rim, edges)
    assert found is not None and found.step == "the camera"
    assert found.alternatives == ("the intersection",) and found.recall == 1.0
    assert "silhouettes" in found.sentence
    assert on_silhouettes(rim | (r < 5), edges) is None
    assert on_silhouettes(rim, None) is None and on_silhouettes(np.zeros_like(rim), edges) is None


def test_two_classes_that_differ_whole_are_both_named_with_the_step_they_share() -> None:
    # A normal written p - c/r (an operator-precedence slip): every reflected path and every
    # lit diffuse surface differs. Naming "the reflection is wrong" alone, as the red-team's
    # C program was told, would be false: both are named, and the normal they share.
    paths = np.full((20, 20), PATH_BITS["CAMERA_MISS"], np.int64)
    paths[:9] = PATH_BITS["MIRROR"] | PATH_BITS["MIRROR_HIT"]
    paths[9] = PATH_BITS["DIFFUSE_LIT"]
    differing = np.zeros((20, 20), bool)
    differing[:10] = True
    found = locate(differing, paths)
    assert found is not None and found.step == "reflection"
    assert "direct light" in found.alternatives and "normal" in found.alternatives
    assert "the other 20 exactly those whose path reaches a diffuse surface" in found.sentence
    assert found.sentence.endswith("the hit point or its normal")
    # A few stray pixels elsewhere (under SECOND_SHARE of them) leave one step named.
    differing[9] = False
    differing[9, :2] = True
    alone = locate(differing, paths)
    assert alone is not None and "normal" not in alone.alternatives
    assert alone.sentence.endswith("the reflection is wrong"), alone.sentence
