"""The diagnosis (compare/diagnose/search.py) as the report and the gradebook show it: what an
image implements, a short reason for a gradebook cell, and evidence pictures per explaining
change (the image beside the candidate it was explained by, and their difference before and
after the change).

Candidates render through the render cache (CandidateRenderer), so a class's diagnoses share
their renders. Inputs are paths and plain values, so it runs in grade's worker
processes and on Dask workers alike.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from compare.diagnose.mistakes import catalogue
from compare.diagnose.renderer import CandidateRenderer
from compare.diagnose.search import DiagnoseOptions, Diagnosis, FlipSeed, diagnose, unmirror
from compare.diagnose.transforms import of_spec
from compare.judge.images import Image, linear_to_srgb
from compare.judge.png import FAST, write_display_png
from compare.judge.quirks import QUIRKS
from compare.render.cache import RenderCache
from safe_files.content import json_safe
from scene_model.scene import load_scene

DIFF_GAIN = 8  # |difference| x 8 in display values, as grade's difference picture


def describe_cause(cause: str) -> str:
    """A step's cause in words for a gradebook: "+Q2" -> "Q2 (eta = 1/ior also when leaving
    glass)", "no_offset" -> "mistake no_offset", "--no-shadows" -> "shadows switched off",
    "ior 1.5" -> "ior 1.5 for every glass sphere", "mirrored left-right" -> "image mirrored
    left-right"."""
    if cause[:2] in ("+Q", "-Q") and cause[2:].isdigit():
        q = int(cause[2:])
        what = QUIRKS.get(q, "")
        return f"Q{q} ({what})" if cause[0] == "+" else f"Q{q} fixed ({what})"
    if cause.startswith("--no-"):
        return f"{cause[5:]} switched off"
    if cause.startswith("+") and not cause[1:].startswith("Q"):
        return f"{cause[1:]} switched on"
    if cause.startswith(("max depth", "scene ")):
        return cause
    if cause.startswith("mirrored"):
        return f"image {cause}"
    if cause.startswith(("background", "light at", "colour of")):
        return f"{cause} hard-coded"
    if cause.startswith("ior"):
        # "ior 1.45 for 'middle'" names its sphere already
        return f"{cause} hard-coded" if " for '" in cause else f"{cause} for every glass sphere"
    name = cause.lstrip("-")
    if name in catalogue():
        return f"mistake {name}" if not cause.startswith("-") else f"without mistake {name}"
    return cause


def short_reason(d: Diagnosis, assigned: str | None = None) -> str:
    """One gradebook cell: "looks like Q2 (eta = 1/ior also when leaving glass)", "looks like
    mistake no_offset", "not explained: refraction (6,078 px, 100 %)". The mode is named when
    it is not the assigned model's ("looks like paper, Q8 fixed (...)"). It says "looks like"
    a candidate only for what the candidate explains, and never that the image matches a model
    it does not match exactly (the verdict's judging, compare/judge/exact_match.py)."""
    items = [describe_cause(c) for c in d.causes]
    # The start mode is a claim only where the image tells it from the assigned model.
    if assigned is not None and d.start != assigned and assigned not in d.modes_as_near():
        items.insert(0, d.start)
    text = f"looks like {', '.join(items)}" if items else ""
    partly = [f for f in d.effects.values() if f.state == "partly explained"]
    if partly:
        text += "; still differing: " + ", ".join(
            f"{f.effect} {f.final_differing:,} px" for f in partly
        )
    if d.unexplained:
        text += (
            ("; " if text else "")
            + "not explained: "
            + ", ".join(
                f"{k} ({d.effects[k].final_differing:,} px, "
                f"{d.effects[k].final_differing / d.effects[k].pixels:.0%})"
                for k in d.unexplained
            )
        )
    if text:
        return text
    return f"looks like {d.result}" if d.matches else f"nearest to {d.result}"


def render_command(d: Diagnosis, scene_file: str | Path) -> str:
    """The rtdemo command that renders the diagnosis, with what a copy of the scene must
    change first (a hard-coded background or ior) and how the image was mirrored."""
    changes = d.scene_changes
    words = []
    if "background" in changes:
        words.append("background " + ", ".join(f"{v:g}" for v in changes["background"]))
    if "ior" in changes:
        where = changes.get("ior_sphere")
        which = f"the glass sphere '{where}'" if where else "every glass sphere"
        words.append(f"ior {changes['ior']:g} for {which}")
    if "bias" in changes:
        words.append(f"bias {changes['bias']:g}")
    if "light" in changes:
        words.append("the light at (" + ", ".join(f"{v:g}" for v in changes["light"]) + ")")
    if "colour" in changes:
        rgb = ", ".join(f"{v:g}" for v in changes["colour"]["rgb"])
        words.append(f"the colour of '{changes['colour']['sphere']}' ({rgb})")
    if "camera" in changes:
        pos, at = (
            ", ".join(f"{v:g}" for v in changes["camera"][k]) for k in ("position", "look_at")
        )
        words.append(f"the camera at ({pos}) looking at ({at})")
    scene = f"{scene_file}" + (f" (a copy with {' and '.join(words)})" if words else "")
    text = f"rtdemo render {scene} {' '.join(d.rtdemo_args)}"
    if d.mirrored:
        text += f", then mirrored {d.mirrored}"
    for transform in d.image_transforms:
        text += f", then {transform}"
    return text


class _Evidence:
    """The evidence pictures of one diagnosis, written to `folder` as PREFIX-*.png: each
    candidate once, beside the image's difference from it (against the un-mirrored image:
    the candidates are what the program computed)."""

    def __init__(
        self, image: Image, d: Diagnosis, render: CandidateRenderer, folder: Path, prefix: str
    ) -> None:
        self.d, self.render, self.folder, self.prefix = d, render, folder, prefix
        rgb = unmirror(image.rgb, d.mirrored)
        # The writer's transforms as the search judged them: the image undone where they
        # move pixels, every candidate shown through them where they change values.
        found = [of_spec(spec) for spec in d.image_transform_specs]
        for t in found:
            rgb = t.undo(rgb) if t.undo is not None else rgb
        self.values = [t for t in found if t.undo is None]
        self.test = linear_to_srgb(np.nan_to_num(rgb, nan=0.0, posinf=1.0))
        self.shown: dict[str, tuple[str, str]] = {}  # candidate name -> (its PNG, its diff)

    def picture(self, name: str) -> tuple[str, str]:
        """The file names of the PNGs of the candidate called `name` and of its difference."""
        if name not in self.shown:
            c = self.d.candidates[name]
            i = len(self.shown)
            shown = self.render(c).rgb
            for t in self.values:
                shown = t.apply(shown)
            disp = linear_to_srgb(np.nan_to_num(shown, nan=0.0, posinf=1.0))
            diff = np.abs(self.test - disp) * DIFF_GAIN
            for kind, data in (("candidate", disp), ("diff", diff)):
                path = self.folder / f"{self.prefix}-{kind}-{i}.png"
                write_display_png(path, data, compress_level=FAST)
            self.shown[name] = (f"{self.prefix}-candidate-{i}.png", f"{self.prefix}-diff-{i}.png")
        return self.shown[name]

    def entries(self, href: str) -> list[dict[str, Any]]:
        """Per step (or, with none, for the result): the candidate after it and the image's
        difference from the candidate before and after; pictures named href + file."""
        d, out = self.d, []
        before = d.start
        for s in d.steps:
            flip = {
                k: [d.effects[k].start_flip, d.effects[k].final_flip]
                for k in s.explains
                if k in d.effects
            }
            out.append(
                self._entry(href, s.change, s.cause, s.candidate, list(s.explains), flip, before)
            )
            before = s.candidate
        if not d.steps:
            out.append(self._entry(href, f"nearest: {d.result}", "", d.result, [], {}, d.result))
        return out

    def _entry(
        self,
        href: str,
        change: str,
        cause: str,
        candidate: str,
        explains: list[str],
        flip: dict[str, list[float]],
        before: str,
    ) -> dict[str, Any]:
        before_png, before_diff = (href + p for p in self.picture(before))
        png, diff = (href + p for p in self.picture(candidate))
        return {
            "change": change,
            "cause": cause,
            "candidate": candidate,
            "explains": explains,
            "flip": flip,
            "before": before,
            "before_png": before_png,
            "before_diff": before_diff,
            "candidate_png": png,
            "diff": diff,
        }


@dataclass(frozen=True)
class EvidenceOptions:
    """How diagnose_image runs and names what it writes: `prefix` of the evidence PNGs, `href`
    before their names in the dict, `assigned` the model the image was judged against (the
    gradebook cell names the mode when it differs), `parallel` renders at once, `progress`
    where progress lines go, `flip_seed` diagnose's."""

    prefix: str = "diagnosis"
    href: str = ""
    assigned: str | None = None
    parallel: int = 1
    progress: Callable[[str], None] | None = None
    flip_seed: FlipSeed | None = None


def diagnose_image(
    image: Image,
    scene_file: str | Path,
    cache: RenderCache | str | Path,
    evidence_dir: str | Path,
    options: EvidenceOptions | None = None,
) -> dict[str, Any]:
    """The diagnosis of `image` (a render of `scene_file`) as a JSON-ready dict: Diagnosis
    .as_dict() plus `short` (the gradebook cell), `evidence` (pictures per explaining change,
    written to evidence_dir as PREFIX-*.png, named href + file in the dict) and the cache's
    renders and hits. `cache`: the render cache the candidates are rendered through (or its
    folder). Raises DiagnoseError or ToolError when the image cannot be diagnosed."""
    o = options or EvidenceOptions()
    scene = load_scene(scene_file)
    h, w = image.shape
    folder = Path(evidence_dir)
    folder.mkdir(parents=True, exist_ok=True)
    threads = 1 if o.parallel > 1 else 0
    with CandidateRenderer(scene_file, w, h, threads=threads, cache=cache) as render:
        how = DiagnoseOptions(progress=o.progress, parallel=o.parallel, flip_seed=o.flip_seed)
        d = diagnose(image, scene, render, how)
        evidence = _Evidence(image, d, render, folder, o.prefix).entries(o.href)
        out = d.as_dict()
        out |= {
            "short": short_reason(d, o.assigned),
            "command": render_command(d, Path(scene_file).name),
            "evidence": evidence,
            "assigned": o.assigned,
            "cache": {"rendered": render.rendered, "hits": render.cache_hits},
        }
    result: dict[str, Any] = json_safe(out)
    return result
