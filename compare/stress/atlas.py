"""`rtval stress`: where each method breaks, before it misleads anyone.

For every stress scene (scenes/stress/*.json) and method (demo paper/classic/physical on CPU
and GL, Mitsuba whitted and path): NaN/Inf counts, error against the Whitted reference, and
stability — how far the image moves (mean FLIP) when the scene is nudged: bias x10 and /10,
the camera moved by 1e-4, and (path only) another seed. Writes reports/stress/index.html
(an atlas: thumbnails and a sentence per failure) and stress.json. Each scene also says which
effects it shows and which do not occur in it (no light: no direct light, no shadows), from
the reference's camera-ray AOVs.
"""

from __future__ import annotations

import json
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from compare.judge.effects import EFFECTS, effect_masks
from compare.judge.evaluate import evaluate_pair
from compare.judge.images import Image, read_image
from compare.judge.png import write_linear_png
from compare.judge.scoring import ABSENT
from compare.pages.writer import write_page
from compare.render.cache import RenderCache
from compare.render.jobs import RenderJob, run_jobs
from compare.render.progress import Progress
from safe_files.content import json_safe
from safe_files.paths import own_folder, require_folder, write_atomic
from scene_model.scene import Scene, load_scene

DEMO_METHODS = [
    (f"demo {mode} {backend}", mode, backend)
    for mode in ("paper", "classic", "physical")
    for backend in ("cpu", "gl")
]
REF_METHODS = ["mitsuba whitted", "mitsuba path"]
UNSTABLE_FLIP = 0.05  # a nudge moving the image by more than this is called unstable
WRONG_FLIP = 0.05  # physical mode further than this from the reference is flagged


@dataclass
class MethodResult:
    method: str
    nan: int
    inf: int
    flip_vs_reference: float | None
    ssim_vs_reference: float | None
    stability: dict[str, float] = field(default_factory=dict)
    thumbnail: str = ""
    sentences: list[str] = field(default_factory=list)

    @property
    def worst_stability(self) -> float:
        return max(self.stability.values(), default=0.0)


def _perturbed(scene_file: Path, folder: Path) -> dict[str, Path]:
    raw = json.loads(scene_file.read_text())
    out = {"base": scene_file}
    nudges: tuple[tuple[str, Callable[[dict[str, Any]], None]], ...] = (
        ("bias x10", lambda j: j.__setitem__("bias", j.get("bias", 1e-4) * 10)),
        ("bias /10", lambda j: j.__setitem__("bias", j.get("bias", 1e-4) / 10)),
        (
            "camera +1e-4",
            lambda j: j.setdefault("camera", {}).__setitem__(
                "position", [p + 1e-4 for p in j.get("camera", {}).get("position", [0, 0, 0])]
            ),
        ),
    )
    for name, change in nudges:
        j = json.loads(json.dumps(raw))
        change(j)
        p = folder / f"{scene_file.stem}-{name.replace(' ', '_').replace('/', 'div')}.json"
        p.write_text(json.dumps(j))
        out[name] = p
    return out


def _effects(scene: Scene, reference: Image) -> tuple[list[str], dict[str, str]]:
    """The effects the scene shows (mask pixels in the reference), and those it does not."""
    masks = effect_masks(scene, reference.aovs["id"], reference.aovs["depth"])
    shown = [k for k in EFFECTS if masks[k].any()]
    return shown, {k: ABSENT for k in EFFECTS if k not in shown}


def _flip(a: np.ndarray, b: np.ndarray) -> float:
    return evaluate_pair(a, b).metrics.flip_ldr


def _jobs(scene_name: str, variants: dict[str, Path], size: tuple[int, int]) -> list[RenderJob]:
    """Every render of one stress scene: each method on the scene and on its nudges."""
    jobs = []
    for method, mode, backend in DEMO_METHODS:
        for name, path in variants.items():
            jobs.append(
                RenderJob(
                    f"{method}|{name}",
                    f"{scene_name}: {method}, {name}",
                    "rtdemo",
                    [
                        "render",
                        "{scene}",
                        "-o",
                        "{out}",
                        "--mode",
                        mode,
                        "--backend",
                        backend,
                        "--width",
                        str(size[0]),
                        "--height",
                        str(size[1]),
                        "-q",
                    ],
                    method,
                    scene=str(path),
                )
            )
    for method in REF_METHODS:
        whitted = method.endswith("whitted")
        names = list(variants) + ([] if whitted else ["seed 1"])
        for name in names:
            jobs.append(
                RenderJob(
                    f"{method}|{name}",
                    f"{scene_name}: {method}, {name}",
                    "rtval",
                    [
                        "reference",
                        "{scene}",
                        "-o",
                        "{out}",
                        "--integrator",
                        "whitted" if whitted else "path",
                        "--light",
                        "point",
                        "--centre-rays",
                        "--spp",
                        "1" if whitted else "16",
                        "--seed",
                        "1" if name == "seed 1" else "0",
                        "--size",
                        f"{size[0]}x{size[1]}",
                    ],
                    method,
                    scene=str(variants.get(name, variants["base"])),
                )
            )
    return jobs


def run_stress(
    scene_files: list[Path],
    out_dir: Path,
    *,
    size: tuple[int, int],
    cache: RenderCache | None = None,
    progress: Callable[[str], None] = print,
) -> dict[str, Any]:
    require_folder(out_dir, missing_ok=True)  # a link there would take the atlas elsewhere
    out_dir.mkdir(parents=True, exist_ok=True)
    own_folder(out_dir, "images")  # never through a link planted there
    cache = cache or RenderCache()
    results: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory(prefix="rtval-stress-") as tmp_name:
        tmp = Path(tmp_name)
        # Every render of every scene in one run: the Mitsuba ones in one process.
        per_scene = []
        for scene_file in scene_files:
            scene = load_scene(scene_file)
            per_scene.append((scene, _jobs(scene.name, _perturbed(scene_file, tmp), size)))
        run_jobs(
            [j for _, jobs in per_scene for j in jobs],
            cache,
            progress=progress if isinstance(progress, Progress) else Progress(),
        )
        for n, (scene, jobs) in enumerate(per_scene, 1):
            results.append(_scene_result(scene, jobs, cache, out_dir))
            progress(f"[{n}/{len(scene_files)}] {scene.name}")
    data = {"size": list(size), "unstable_flip": UNSTABLE_FLIP, "scenes": results}
    data = dict(json_safe(data))  # an undefined SSIM (images under 11 px) is null, not NaN
    write_atomic(out_dir / "stress.json", json.dumps(data, indent=2, default=float) + "\n")
    write_page(out_dir / "index.html", "stress.html.j2", data=data)
    return data


def _scene_result(
    scene: Scene, jobs: list[RenderJob], cache: RenderCache, out_dir: Path
) -> dict[str, Any]:
    """One stress scene: the effects it shows and each method's numbers and thumbnail."""
    renders: dict[str, dict[str, np.ndarray]] = {}
    shown: tuple[list[str], dict[str, str]] = ([], {})
    for job in jobs:
        method, name = job.key.split("|")
        image = read_image(job.exr(cache))
        renders.setdefault(method, {})[name] = image.rgb
        if job.key == "mitsuba whitted|base":
            shown = _effects(scene, image)
    reference = renders["mitsuba whitted"]["base"]
    methods = []
    for method, per in renders.items():
        thumb = f"images/{scene.name}-{method.replace(' ', '-')}.png"
        write_linear_png(out_dir / thumb, per["base"])
        r = _method_result(method, per, reference, thumb)
        methods.append({**r.__dict__, "worst_stability": r.worst_stability})
    return {
        "scene": scene.name,
        "description": scene.description,
        "effects": shown[0],
        "absent_effects": shown[1],
        "methods": methods,
    }


def _method_result(
    method: str, per: dict[str, np.ndarray], reference: np.ndarray, thumb: str
) -> MethodResult:
    """A method's NaN/Inf counts, error against the reference, stability and sentences."""
    base = per["base"]
    against = None if method == "mitsuba whitted" else evaluate_pair(reference, base).metrics
    r = MethodResult(
        method=method,
        nan=int(np.isnan(base).any(-1).sum()),
        inf=int(np.isinf(base).any(-1).sum()),
        flip_vs_reference=None if against is None else against.flip_ldr,
        ssim_vs_reference=None if against is None else against.ssim,
        stability={k: _flip(base, v) for k, v in per.items() if k != "base"},
        thumbnail=thumb,
    )
    if not np.isfinite(base).all():
        r.sentences.append(f"{method}: {r.nan} NaN and {r.inf} Inf pixels.")
    worst = max(r.stability.items(), key=lambda kv: kv[1], default=None)
    if worst and worst[1] > UNSTABLE_FLIP:
        r.sentences.append(
            f"{method}: unstable — '{worst[0]}' moves the image by FLIP {worst[1]:.3f}."
        )
    physical = method.startswith("demo physical")
    if physical and r.flip_vs_reference is not None and r.flip_vs_reference > WRONG_FLIP:
        r.sentences.append(f"{method}: FLIP {r.flip_vs_reference:.3f} from the Whitted reference.")
    return r


def table(data: dict[str, Any]) -> str:
    lines = [
        f"{'scene':<24}{'method':<22}{'NaN':>7}{'Inf':>6}{'FLIP ref':>10}{'stability':>11}  worst nudge"
    ]
    for s in data["scenes"]:
        for m in s["methods"]:
            worst = max(m["stability"].items(), key=lambda kv: kv[1], default=("-", 0.0))
            flip = "-" if m["flip_vs_reference"] is None else f"{m['flip_vs_reference']:.4f}"
            lines.append(
                f"{s['scene']:<24}{m['method']:<22}{m['nan']:>7}{m['inf']:>6}{flip:>10}"
                f"{m['worst_stability']:>11.4f}  {worst[0]}"
            )
    return "\n".join(lines)
