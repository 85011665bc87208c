"""Explains a foreign image as the nearest demo model: which mode, which quirks present or
absent, which effects switched off, which recursion depth, which scene constants (background,
glass ior, bias), which named mistakes (mistakes.json) and which transforms of the image's
writer (transforms.py) reproduce it, effect by effect (docs/diagnosis.md).

The search renders candidates through an injected Renderer (score.Renderer; this module starts
no process) and scores each against the image per effect (score.py; trials.py keeps them). It
starts from the mode that matches most pixels of the whole image, and from every mode within a
clear margin of it; decides whether the image is mirrored and fits the writer's transforms;
then tries one switch at a time (switches.py), keeps the one that lowers the summed per-effect
distance most, clearly helps some effect and makes no other clearly worse, and repeats with the
switches that helped. The result is retold from the simplest mode, and a switch is named only
for effects that pass every gate (gates.py): the verdict's exact match of the pixels that
differed (not through a spread wider than the start's), FLIP over them halved, no effect worse.
A quirk toggle that a constant reproduces as well is told with it. Every candidate's render has
a time limit from the start's cost (trials.limit_time) and a ray budget from the starts' rays
(trials.limit_rays); one over either is skipped and said.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from compare.diagnose import (
    camera_fit,
    camera_view,
    colour_fit,
    constant_fit,
    light_fit,
    localise,
    noise,
    transforms,
)
from compare.diagnose.candidate import RGB, Candidate, Vec3
from compare.diagnose.constant_fit import fitted_bias, fitted_ior
from compare.diagnose.fresnel_fit import fitted_curve
from compare.diagnose.gates import (
    EXPLAINED_SHARE,
    Gate,
    absorbed_pixels,
    changed_pixels,
    followed,
    gates,
)
from compare.diagnose.localise import INT
from compare.diagnose.memo import keep, load, record_name
from compare.diagnose.mistakes import catalogue
from compare.diagnose.record import (
    MODE_CLOSE_RATIO,
    MODE_CLOSE_SHARE,
    Diagnosis,
    EffectFinding,
    Evidence,
    Found,
    ImageCause,
    Step,
    diagnosis,
    finding,
    summary,
)
from compare.diagnose.score import (
    MIRRORS,
    DiagnoseError,
    NoFinitePixels,
    Renderer,
    Store,
    Target,
    check_finite,
    explained,
    objective,
    unmirror,
    worsened,
)
from compare.diagnose.switches import (
    MAX_SEARCH_DEPTH,
    VALUED,
    Switch,
    differences,
    simplest,
    switches,
    undone,
)
from compare.diagnose.trials import Trials
from compare.judge import flip_crops, metrics
from compare.judge.arrays import F32
from compare.judge.effects import BOOL, EFFECTS
from compare.judge.exact_match import exact_match
from compare.judge.images import Image
from compare.judge.target_model import QUIRK_COUNT, TargetModel
from scene_model.scene import Scene

__all__ = [
    "BASE_QUIRKS",
    "EXPLAINED_SHARE",
    "LATER_QUIRKS",
    "MAX_RENDERS",
    "MAX_SEARCH_DEPTH",
    "SEARCH_QUIRKS",
    "DiagnoseError",
    "DiagnoseOptions",
    "Diagnosis",
    "EffectFinding",
    "FlipSeed",
    "FunctionRenderer",
    "NoFinitePixels",
    "Renderer",
    "Step",
    "diagnose",
    "unmirror",
]

BASE_QUIRKS = tuple(range(1, 10))  # Q10 only matters with --spp > 1
LATER_QUIRKS = (11, 12, 13)  # searched where rtdemo renders them (CandidateRenderer says)
SEARCH_QUIRKS = BASE_QUIRKS + LATER_QUIRKS
# A switch is kept when it lowers the objective by MIN_GAIN (and some effect's distance
# clearly: diagnose_score.explained).
MIN_GAIN = 1e-3
MAX_RENDERS = 200  # no new full sweep of every switch starts beyond this many renders
MAX_ROUNDS = 40
# A kept candidate whose own perturbed renders moved CHAOS_RATIO times as many pixels of each
# effect as still differ is settled: the rest is where float rounding decides its pixels (a
# mistake's acne), which no further switch reproduces, so no second full sweep is made.
CHAOS_RATIO = 4
# Below this share of a model's sphere outlines covered by the image's edges, its spheres are
# not where the model draws them (camera_view.outline_share): measured at 320x240, every
# red-team, real and correct image with the model's geometry 0.41-0.97 (0.41: a camera
# explained exactly); a discriminant without its 4, a radius for its square, a field of view
# in degrees 0.01-0.06. Shading causes named on such an image were false.
OUTLINES_MIN = 0.2
# No new full sweep starts after this many seconds of search: with the time limit of each
# render (trials.TIME_LIMIT_MAX) a 640x480 diagnosis ends within 30 s, whatever the image.
SEARCH_SECONDS = 15.0
# Switches tried in every round, not only where they helped in the last full sweep: the
# depth, and the colours fitted against the current candidate (colour_switches).
FITTED_EACH_ROUND = ("depth", "colour")
# The light is fitted only where at least this share of the directly lit pixels differ: moved
# sideways it changes 18.5 % of them at 0.25 (light_fit.MIN_MOVE), 39 % at 0.5, 81 % at 1
# (classic.json at 320x240); a few differing are something else.
LIGHT_MIN_SHARE = 0.15
# Mistakes that move every pixel's tone: the nearest mode is chosen with and without them, so
# that a gamma-encoded paper image is not taken for physical mode (it starts from paper).
TONE_MISTAKES = ("double_gamma",)
# A camera slip moves every silhouette, so the modes cannot be told apart until it is undone.
# Where the nearest start leaves over CAMERA_TRY_SHARE of the pixels differing, each camera
# mistake of the catalogue is tried on every start (on the nearest alone, a classic image whose
# modes all come close was judged on physical's colours and its row-by-width camera lost); one
# that halves the count (CAMERA_RATIO) is kept, and the modes are compared through it, as
# through a tone mistake.
CAMERA_TRY_SHARE = 0.25
CAMERA_RATIO = 0.5
# Where the nearest start is that far off, every start within this ratio of its count is
# searched from too.
FAR_MODE_RATIO = 1.5
# The nearest mode is the one matching most pixels, unless none matches this share of them.
MODE_MATCH_MIN = 0.05
# The image is taken as mirrored when a flipped copy is at most MIRROR_RATIO as far from the
# nearest mode as the image itself, by at least MIRROR_MIN (a share of all pixels). A scene
# symmetric about the flip gives both the same distance, so it can never trigger.
MIRROR_RATIO = 0.5
MIRROR_MIN = 0.02
MODES = ("classic", "paper", "physical")
FlipSeed = tuple[F32, F32, BOOL]  # a render, its LDR-FLIP map against the image, where it holds


class Search:
    """One diagnosis: the image, every candidate tried (Trials) and the phases that choose
    between them, in the order `run` calls them."""

    def __init__(
        self,
        image: Image,
        scene: Scene,
        trials: Trials,
        quirks: Sequence[int],
        max_renders: int,
        say: Callable[[str], None],
    ) -> None:
        self.t0 = time.perf_counter()
        self.image, self.scene, self.trials = image, scene, trials
        self.quirks, self.max_renders, self.say = tuple(quirks), max_renders, say
        self.gated: dict[tuple[Candidate, Candidate], dict[str, Gate]] = {}
        self.images: list[ImageCause] = []  # the writer's transforms found (transformed)
        # a camera mistake or fitted camera (a switch) the modes are judged with
        self.camera_slips: tuple[Switch, ...] = ()
        self.outlines = 1.0  # the scene camera's outlines the image's edges cover (begin)
        self.near_by_count: list[Candidate] = []  # the nearest start and those within its margin
        self.banned: set[tuple[str, str]] = set()  # switches of a dead end (searched)
        self.noisy = False  # the image carries random noise (denoised)
        self.seen: RGB | None = None  # the background the image shows (_background_seen)
        self.seen_for: F32 | None = None  # ... in this test image
        self.lights: dict[tuple[int, Candidate], list[Vec3]] = {}  # light_switches, per start
        self.colours: dict[tuple[int, Candidate], list[tuple[str, RGB]]] = {}  # colour_switches

    def run(self, starts: list[Candidate]) -> Diagnosis:
        t = self.trials
        mirrored, begins = self.begin(starts)
        for b in begins:
            t.flip_soon(b)  # the start's FLIP and exact match while the search runs
            t.exact_soon(b)
        modes = {c.name: float(t.whole_differing(c)) for c in starts}
        # Where two modes come close, each is searched and the better explanation told: a
        # classic program with one shading bug may be a hair nearer physical by count.
        found = min(self._explained(begins, mirrored), key=self.left_over)
        skipped = tuple(f"{c.name} ({why})" for c, why in t.skipped.items())
        found = dataclasses.replace(found, skipped=skipped, images=tuple(self.images))
        if len(begins) > 1:
            self.say(f"diagnose: told from {found.begin.name}, the better explanation")
        outlines = self.outline_share(found.result) if self.outlines < OUTLINES_MIN else 1.0
        if outlines < OUTLINES_MIN:
            self.say(f"diagnose: the spheres lie elsewhere than {found.result.name} draws them")
            found = dataclasses.replace(found, result=found.begin, steps=[], images=())
        findings, text = self.report(found)
        where = self.localised(found.result, findings)
        if outlines < OUTLINES_MIN:
            where["overall"] = [localise.outlines_elsewhere(outlines, OUTLINES_MIN).as_dict()]
        seconds = time.perf_counter() - self.t0
        self.say(f"diagnose: {found.result.name} after {len(t.scores)} renders in {seconds:.1f} s")
        facts = {
            "mode_objectives": modes,
            "renders": len(t.scores),
            "seconds": seconds,
            "candidates": found.candidates,
            "localisation": where,
        }
        return diagnosis(self.scene, self.image.path, found, findings, text, facts)

    def outline_share(self, c: Candidate) -> float:
        """How much of c's sphere outlines the image's edges cover (camera_view), from its
        render's id AOV: its camera may be a fitted one."""
        ids = self.trials.render.with_aovs(c).aovs["id"]
        return camera_view.outline_share(self.trials.target.test, ids)

    # --- where to begin ------------------------------------------------------------------

    def _explained(self, begins: list[Candidate], mirrored: str) -> list[Found]:
        """The explanation from each begin, while the search has time (SEARCH_SECONDS): the
        first always. Several begins are searched in the order of how far one switch brings
        each (its first round, which the search reuses): the one a single mistake explains
        first, so that an exact explanation ends the search early."""
        if len(begins) > 1:
            begins = sorted(begins, key=self.one_step_objective)
        out = [self.explain(begins[0], mirrored)]
        for b in begins[1:]:
            exact = next((f for f in out if self.left_over(f)[0] == 0), None)
            if exact is not None:
                self.say(f"diagnose: {exact.result.name} matches exactly: {b.name} not searched")
                break
            if time.perf_counter() - self.t0 > SEARCH_SECONDS:
                self.say(f"diagnose: no time left to search from {b.name} too")
                break
            out.append(self.explain(b, mirrored))
        return out

    def one_step_objective(self, begin: Candidate) -> float:
        """The objective after the best switch of begin's first round."""
        _, _, gains = self._round(begin, None)
        return objective(self.trials.per(begin)) - max(gains, default=0.0)

    def left_over(self, found: Found) -> tuple[int, int]:
        """How much an explanation leaves: pixels still differing from its result (the
        verdict's exact match), then its number of steps."""
        left = sum(self.trials.exact_differing(found.result).values())
        return left, len(found.steps)

    def begin(self, starts: list[Candidate]) -> tuple[str, list[Candidate]]:
        """Renders the starts (each also with the tone mistakes), decides whether the image is
        mirrored (judging the un-mirrored image from then on) and picks the nearest start."""
        toned = [c.with_mistake(m, True) for c in starts for m in TONE_MISTAKES]
        self.say(
            f"diagnose: rendering {', '.join(c.name for c in starts)} "
            f"(and with {', '.join(TONE_MISTAKES)})"
        )
        self.trials.keep.update(starts + toned)
        self.trials.evaluate(starts + toned)
        limit = self.trials.limit_time(starts + toned)
        if limit is not None:
            self.say(f"diagnose: each candidate may render for {limit:.1f} s")
        budget = self.trials.limit_rays(starts + toned)
        if budget is not None:
            self.say(f"diagnose: each candidate may trace {budget} rays")
        mirrored = self.mirrored(starts + toned)
        self.camera_slips = self.camera_slip(starts)
        self.outlines = camera_view.scene_outline_share(self.trials.target.test, self.scene)
        begins = self.nearest(starts)
        # The writer's transforms are fitted against the nearest start and those close to it by
        # count, not against the far-off ones searched only because every start is far.
        fitted_on = [c for c in begins if c in self.near_by_count]
        if self.denoised(begins[0]):  # the modes are judged again without the noise
            begins = self.nearest(starts)
            fitted_on = [c for c in begins if c in self.near_by_count]
        # A writer's transform fitted over spheres drawn elsewhere only rescales what is there.
        outlines_off = self.outlines < OUTLINES_MIN and not self.camera_slips
        if not outlines_off and self.transformed(fitted_on):  # judged again through it
            begins = self.nearest(starts)
        self.trials.keep_only(set(begins))
        return mirrored, begins

    def denoised(self, begin: Candidate) -> bool:
        """Fits random noise (noise.py) on the image against begin's render; where it passes
        the gates, it is named and the search judges the image without it from then on."""
        t = self.trials
        render = t.centre(begin).rgb
        tr = noise.fitted(t.target.test, render, t.target.codes)
        if tr is None or tr.undo is None:
            return False
        undone = tr.undo(t.target.test)
        g = self._transform_gates(render, tr, undone)
        named = tuple(k for k in t.target.masks if k in g and g[k].passed)
        if not named:
            self.say(f"diagnose: {tr.name}, but it fails the gates")
            return False
        self.say(f"diagnose: the image has {tr.name}")
        self.images.append(ImageCause(tr.family, tr.name, named, {k: g[k] for k in named}, tr.spec))
        t.set_test(undone)
        self.noisy = True
        return True

    def transformed(self, begins: list[Candidate]) -> bool:
        """Fits the writer's transforms (transforms.py) on the image against each begin's
        render; the best that passes the gates is named and the search judges through it
        from then on."""
        t = self.trials
        fits = [
            (fit, t.centre(b).rgb)
            for b in begins
            if (fit := transforms.best(t.target.test, t.centre(b).rgb, t.target.codes))
        ]
        if not fits:
            return False
        (tr, d0, d1), render = min(fits, key=lambda f: f[0][2])
        g = self._transform_gates(render, tr)
        named = tuple(k for k in t.target.masks if k in g and g[k].passed)
        if not named or any(x.worse for x in g.values()):
            self.say(f"diagnose: {tr.name} fits ({d0:.3f} -> {d1:.3f}) but fails the gates")
            return False
        self.say(f"diagnose: the image has {tr.name} (distance {d0:.3f} -> {d1:.3f})")
        self.images.append(ImageCause(tr.family, tr.name, named, {k: g[k] for k in named}, tr.spec))
        if tr.undo is not None:
            t.set_test(tr.undo(t.target.test))
        else:
            t.set_values(tr)
        return True

    def _transform_gates(
        self, render: F32, tr: transforms.Transform, undone: F32 | None = None
    ) -> dict[str, Gate]:
        """gates.py for begin's render as it is and transformed, judged at pixel centres
        against the image, or, given `undone`, as it is against the image and the image
        undone (the noise taken out)."""
        t = self.trials
        test, enc, masks = t.target.test, t.target.image.encoding, t.target.masks
        shown = tr.apply(render)
        after = test if undone is None else undone
        e0 = exact_match([render], test, enc, model="start", masks=masks)
        e1 = exact_match([shown], after, enc, model=tr.name, masks=masks)
        flips = (
            flip_crops.cropped_ldr_flip(metrics.display(render), metrics.display(test)),
            flip_crops.cropped_ldr_flip(metrics.display(shown), metrics.display(after)),
        )
        none = np.zeros(test.shape[:2], bool)
        out = gates(e0, e1, none, lambda: (flips[0], flips[1]), masks)
        # The cause's evidence: FLIP over the pixels that differed, whichever gate decided.
        for k, g in out.items():
            d = ~e0.matches & masks[k]
            means = tuple(float(f[d].mean()) if d.any() else 0.0 for f in flips)
            out[k] = dataclasses.replace(g, flips=(means[0], means[1]))
        return out

    def mirrored(self, cands: list[Candidate]) -> str:
        """ "" or the MIRRORS word for the flip that fits the nearest candidate far better
        than the image as it is; the search then judges the un-mirrored image."""
        dist = self.trials.target.mirror_distances([self.trials.kept[c] for c in cands])
        key = min(MIRRORS, key=lambda k: dist[k])
        if not (dist[key] <= MIRROR_RATIO * dist[""] and dist[""] - dist[key] >= MIRROR_MIN):
            return ""
        self.say(
            f"diagnose: the image is mirrored {MIRRORS[key]} (distance {dist['']:.3f} as it "
            f"is, {dist[key]:.3f} un-mirrored); diagnosing the un-mirrored image"
        )
        self.trials.set_test(unmirror(self.image.rgb, key))
        return MIRRORS[key]

    def _toned_best(self, c: Candidate) -> Candidate:
        """c or c with a tone mistake (or the camera slip found), whichever leaves fewer
        pixels differing."""
        toned = [c, *(c.with_mistake(m, True) for m in TONE_MISTAKES)]
        toned += [sw.apply(c, self.scene) for sw in self.camera_slips]
        return min(toned, key=self.trials.whole_differing)

    def camera_slip(self, starts: list[Candidate]) -> tuple[Switch, ...]:
        """The catalogue's camera mistake or the camera fitted from the silhouettes
        (camera_fit.py) that, on some start, halves the fewest pixels differing from any
        start, when every start is far off (CAMERA_TRY_SHARE): the mode cannot be judged
        before the silhouettes fit. () when the starts place them."""
        t = self.trials
        plain = min(t.whole_differing(c) for c in starts)
        if plain <= CAMERA_TRY_SHARE * t.total_pixels():
            return ()
        changes = [Switch("mistake", m, True) for m in camera_mistakes()]
        changes += self.fitted_cameras(starts)
        tried = {sw.apply(c, self.scene): sw for c in starts for sw in changes}
        t.evaluate(list(tried))
        best = min(tried, key=t.whole_differing)
        if t.whole_differing(best) > CAMERA_RATIO * plain:
            return ()
        slip = tried[best]
        self.say(f"diagnose: the silhouettes fit {slip.cause()}; the modes are compared through it")
        return (slip,)

    def fitted_cameras(self, starts: list[Candidate]) -> list[Switch]:
        """The cameras fitted from the image's silhouettes against the starts' (camera_fit.py),
        and the views whose sphere boundaries they follow (camera_view.py)."""
        test = self.trials.target.test
        renders = [self.trials.centre(c).rgb for c in starts]
        found: list[camera_fit.Fitted | camera_view.View] = []
        found += camera_fit.fitted(test, renders, self.scene.camera.fov_y)
        if camera_view.stories(self.scene):
            found += camera_view.fitted(camera_view.image_edges(test), self.scene)
        for f in found[:1]:
            self.say(f"diagnose: the camera fitted from the silhouettes: {f.words}")
        return [Switch("camera", f.key, True) for f in found]

    def fitted(self, kept: Switch, current: Candidate) -> Candidate:
        """current, whose last switch set a constant's seed value, with that value fitted
        (fresnel_fit.py, constant_fit.py); else current."""
        if not kept.present or kept.kind not in ("fresnel", "ior", "bias"):
            return current
        fit = {"fresnel": fitted_curve, "ior": fitted_ior, "bias": fitted_bias}[kept.kind]
        t0, renders = time.perf_counter(), len(self.trials.scores)
        out = fit(self.trials, current)
        self.say(
            f"diagnose: the {kept.kind} fitted: {out.name} ({len(self.trials.scores) - renders}"
            f" renders, {time.perf_counter() - t0:.1f} s)"
        )
        return out

    def background_switches(self, current: Candidate) -> list[Switch]:
        """The background the image shows where the start's camera rays miss every sphere,
        as a switch, where it is not the scene's; and the scene's background back, where
        current hard-codes one. Black is left to the catalogue's mistake black_background,
        which renders the same. A white that clips (any value >= 1 looks the same there) is
        tried as 1 and as 2: glass and mirrors that mix it in may still tell them apart."""
        if current.background is not None:
            return [Switch("background", "scene", False)]
        seen = self._background_seen()
        if seen is None or max(seen) == 0:
            return []
        options = [seen] if min(seen) < 1 else [(1.0, 1.0, 1.0), (2.0, 2.0, 2.0)]
        theirs = tuple(self.scene.background)
        return [
            Switch("background", ",".join(f"{v:g}" for v in rgb), True)
            for rgb in options
            if rgb != theirs
        ]

    def _background_seen(self) -> RGB | None:
        """constant_fit.background_seen of the image judged now, read once per image (every
        round asks; the image changes only when a transform or the noise is taken out)."""
        t = self.trials.target
        misses = t.masks.get("background")
        if misses is None:
            return None
        if self.seen_for is not t.test:
            self.seen, self.seen_for = constant_fit.background_seen(t.test, misses), t.test
        return self.seen

    def light_switches(self, current: Candidate) -> list[Switch]:
        """Where the image's directly lit surfaces put the scene's one light (light_fit.py),
        as switches, where current's shading has the cosine (no Q11 or Q12); the scene's
        light back, where current moves it."""
        if current.light is not None:
            return [Switch("light", "scene", False)]
        t = self.trials.target
        direct = t.masks.get("direct")
        if {11, 12} & current.quirks or direct is None:
            return []
        if self.trials.differing(current)["direct"] < LIGHT_MIN_SHARE * int(direct.sum()):
            return []
        plain = Candidate(current.mode, current.quirks)
        key = (id(t.test), plain)
        if key not in self.lights:
            start = self.trials.render.with_aovs(plain)
            found = light_fit.lights_seen(t.test, start, direct, self.scene, t.image.encoding)
            self.lights[key] = found
        return [Switch("light", ",".join(f"{v:g}" for v in c), True) for c in self.lights[key]]

    def colour_switches(self, current: Candidate) -> list[Switch]:
        """The sphere colours the image shows against current's render (colour_fit.py), as
        switches, fitted again whenever current changes (a lost direct light darkens what
        glass shows: fitted against the start, the glass's colour does not show); the scene's
        colours back, where current types one."""
        if current.colour is not None:
            return [Switch("colour", "scene=0,0,0", False)]
        t = self.trials.target
        key = (id(t.test), current)
        if key not in self.colours:
            start = self.trials.render.with_aovs(current)
            self.colours[key] = colour_fit.colours_seen(t.test, start, self.scene, t.image.encoding)
        return [
            Switch("colour", f"{name}=" + ",".join(f"{v:g}" for v in rgb), True)
            for name, rgb in self.colours.get(key, [])
        ]

    def camera_switches(self, current: Candidate) -> list[Switch]:
        """The fitted camera as a switch of the search (the catalogue's camera mistakes are
        switches already)."""
        fitted = [sw for sw in self.camera_slips if sw.kind == "camera"]
        if current.camera is not None:
            return [Switch("camera", current.camera, False)]
        return fitted

    def nearest(self, starts: list[Candidate]) -> list[Candidate]:
        """The start whose pixels match the image most often, over the whole image: a program
        with one wrong effect is placed by the effects it gets right, not by how near another
        mode comes in the wrong one. Where no start matches MODE_MATCH_MIN of the pixels
        (every tone is off), the one whose pixels are least far off. Each mode counts as near
        as its best with a tone mistake; the search starts from the plain mode, so that the
        mistake is found (and named) as a step of its own."""
        t = self.trials
        total = t.total_pixels()
        counts = {c: t.whole_differing(self._toned_best(c)) for c in starts}
        by_count = min(counts.values()) < (1 - MODE_MATCH_MIN) * total
        if by_count:
            nearest = min(starts, key=lambda c: counts[c])
        else:
            nearest = min(starts, key=lambda c: t.whole(self._toned_best(c)))
        self.say(
            f"diagnose: nearest mode {nearest.name} ("
            + ", ".join(f"{c.name} {counts[c]:,}" for c in starts)
            + f" of {total:,} px differ"
            + ("" if by_count else "; none matches, the nearest by how far pixels are off")
            + ")"
        )
        # Every start far off: a mistake that moves most pixels hides the mode, so each one
        # about as far is searched too (a classic program with its normals turned in is a
        # quarter nearer physical by count).
        far = counts[nearest] > CAMERA_TRY_SHARE * total
        others = [c for c in sorted(starts, key=lambda c: counts[c]) if c != nearest and by_count]
        self.near_by_count = [nearest] + [c for c in others if self._close(counts, c, nearest)]
        far_too = [c for c in others if far and counts[c] <= FAR_MODE_RATIO * counts[nearest]]
        close = [c for c in others if c in self.near_by_count or c in far_too]
        if close:
            self.say(
                f"diagnose: {', '.join(c.name for c in close)} as near: searched from each too"
            )
        return [nearest, *close]

    def _close(self, counts: dict[Candidate, int], c: Candidate, nearest: Candidate) -> bool:
        """Whether c's count of differing pixels is within the clear margin of the nearest's."""
        margin = max(
            MODE_CLOSE_SHARE * self.trials.total_pixels(), MODE_CLOSE_RATIO * counts[nearest]
        )
        return counts[c] - counts[nearest] <= margin

    # --- the search ----------------------------------------------------------------------

    def explain(self, begin: Candidate, mirrored: str) -> Found:
        """The search, then the result without what explains nothing, retold from the mode it
        differs least from in the quirks the scene shows."""
        self.banned = set()  # each begin's search may meet its own dead end
        current = self.searched(begin)
        invisible = self.invisible(current)
        untested = set(range(1, QUIRK_COUNT + 1)) - set(self.quirks) - {10}
        simpler = simplest(current, invisible | untested)
        if simpler.mode != begin.mode:
            self.say(
                f"diagnose: {current.name} is {simpler.name} here; retelling the steps from it"
            )
            begin = Candidate.of_mode(simpler.mode)
            self.trials.evaluate([begin])
        or_more = self.depth_or_more(simpler)
        current, steps, path = self.justified(begin, simpler, or_more)
        or_more = or_more and current.depth(self.scene) == simpler.depth(self.scene)
        cands = {c.name: c for c in (begin, *path, current)}
        return Found(begin, current, steps, invisible, untested, or_more, mirrored, cands)

    def searched(self, begin: Candidate) -> Candidate:
        """The greedy search's result without the switches that explain nothing. Where it
        kept switches and none explains anything, it walked into a dead end (a mistake that
        lowers the distance without matching, such as a ray that never leaves glass for a
        wrong index): it runs once more with those switches banned."""
        found = self.shallowest(self.greedy(begin))
        # Most often the result: its FLIP and exact match while the steps are retold.
        self.trials.flip_guess(found)
        self.trials.exact_soon(found)
        # Switches that explain nothing go first, so that they cannot decide the mode below.
        current, _, _ = self.justified(begin, found, False)
        dead_end = differences(begin, found, self.scene) if current == begin else []
        if not dead_end or self.banned:
            return current
        self.banned = {(sw.kind, sw.key) for sw in dead_end}
        self.say(f"diagnose: a dead end; searching again without {found.name}'s switches")
        return self.searched(begin)

    def greedy(self, current: Candidate) -> Candidate:
        """One switch at a time; later rounds retry only the switches that helped (and the
        depth one up or down), a full sweep again only while some effect is still not
        reproduced."""
        t = self.trials
        if self.noisy:
            # No candidate's codes can match noisy pixels exactly: what differs beyond the
            # noise is localised, not searched.
            self.say("diagnose: no search through the noise: what differs beyond it is localised")
            return current
        promising: set[tuple[str, str]] | None = None  # None: try every switch this round
        for round_no in range(1, MAX_ROUNDS + 1):
            full = promising is None
            tried, cands, gains = self._round(current, promising)
            if full:
                promising = {
                    (sw.kind, sw.key) for sw, g in zip(tried, gains, strict=True) if g > MIN_GAIN
                }
            self.say(
                f"diagnose: round {round_no}: {len(tried)} changes of {current.name}, "
                f"{sum(g > MIN_GAIN for g in gains)} help ({len(t.scores)} renders, "
                f"{time.perf_counter() - self.t0:.1f} s)"
            )
            best = int(np.argmax(gains)) if gains else -1
            if best < 0 or gains[best] <= MIN_GAIN:
                # Settled or not, the shallowest depth that fits as well: its spread (which
                # _settled renders) is then the result's, not a deeper limit's thrown away.
                current = self.shallowest(current)
                if full or self._settled(current):
                    break
                promising = None  # stuck with the switches that helped: one full sweep
                continue
            self.say(
                f"diagnose: keep {tried[best].change(self.scene)}: "
                f"{objective(t.per(current)):.3f} -> {objective(t.per(cands[best])):.3f}"
            )
            current = cands[best]
            current = self.fitted(tried[best], current)
            self.trials.flip_guess(current)  # while the search goes on: often the result
        return current

    def _round(
        self, current: Candidate, promising: set[tuple[str, str]] | None
    ) -> tuple[list[Switch], list[Candidate], list[float]]:
        """The switches of one round (every one, or those that helped and the depth), their
        candidates, and what each gains."""
        t = self.trials
        still = t.open_effects(current)
        tried = [
            sw
            for sw in switches(current, self.scene, self.quirks, full=promising is None)
            + self.camera_switches(current)
            + self.background_switches(current)
            + self.light_switches(current)
            + self.colour_switches(current)
            # the depth and current's own colour fit are tried every round
            if (promising is None or (sw.kind, sw.key) in promising or sw.kind in FITTED_EACH_ROUND)
            and (sw.kind, sw.key) not in self.banned
            and may_help(sw, still)
        ]
        cands = [sw.apply(current, self.scene) for sw in tried]
        t.near(current)
        t.evaluate(cands)
        base = t.per(current)
        # Only a switch that clearly explains some effect counts: small drops spread over
        # every effect are noise fitting (e.g. acne patterns that float rounding decides).
        # One that makes another effect clearly worse is never kept, however much it gains
        # elsewhere: a sign flip that blackens lit surfaces as the image does, but bends the
        # glass wrongly, is not the student's mistake.
        gains = [
            objective(base) - objective(t.per(c))
            if explained(base, t.per(c), still)
            and not worsened(t.scores[current], t.scores[c], t.target.allowance)
            else 0.0
            for c in cands
        ]
        return tried, cands, gains

    def _settled(self, current: Candidate) -> bool:
        """Nothing left to explain: every effect matches (within the allowance, the camera
        turned as exact matching turns it: edge pixels of float64 programs need that), what
        still differs is current's own chaos (CHAOS_RATIO), or the render or time budget is
        spent."""
        t = self.trials
        if len(t.scores) >= self.max_renders or t.matched(current):
            return True
        if time.perf_counter() - self.t0 > SEARCH_SECONDS:
            self.say(f"diagnose: {SEARCH_SECONDS:.0f} s spent: no further sweep")
            return True
        exact = t.exact_of(current)
        if exact.passed:
            return True
        if all(
            e.passed or e.differing * CHAOS_RATIO <= e.unstable for e in exact.per_effect.values()
        ):
            self.say(
                f"diagnose: what still differs lies where {current.name}'s own renders"
                " disagree: no further sweep"
            )
            return True
        return False

    def shallowest(self, c: Candidate) -> Candidate:
        """The smallest recursion limit above the scene's that fits as well as c's: limits
        past the deepest chain the image shows give the same pixels, and the search may have
        jumped past it. Bisection, assuming a deeper limit never fits worse once it fits."""
        lo, hi = self.scene.max_depth, c.depth(self.scene)
        if hi <= lo + 1:
            return c
        while hi - lo > 1:
            mid = (lo + hi) // 2
            at_mid = c.at_depth(mid, self.scene)
            self.trials.evaluate([at_mid])
            lo, hi = (lo, mid) if self.trials.fits_as_well(at_mid, c) else (mid, hi)
        return c.at_depth(hi, self.scene)

    def depth_or_more(self, c: Candidate) -> bool:
        """Whether the deepest limit searched fits as well as c's (the image then tells only
        "at least this deep")."""
        if c.depth(self.scene) <= self.scene.max_depth:
            return False
        deepest = c.with_depth(MAX_SEARCH_DEPTH)
        self.trials.evaluate([deepest])
        return self.trials.fits_as_well(deepest, c)

    def invisible(self, c: Candidate) -> set[int]:
        """Quirks whose toggle leaves c's pixels unchanged: this scene cannot tell them (and
        Q10: every candidate is one ray per pixel, where it changes nothing)."""
        toggles = {q: c.with_quirk(q, q not in c.quirks) for q in self.quirks}
        t = self.trials
        t.evaluate(list(toggles.values()))
        out = {q for q, tog in toggles.items() if t.scores[tog].digest == t.scores[c].digest}
        return out | {10}

    # --- what the result is told as ------------------------------------------------------

    def retell(self, begin: Candidate, final: Candidate) -> list[tuple[Switch, Candidate]]:
        """The switches from begin to final, each in the order that helps most, with the
        candidate after each."""
        remaining = differences(begin, final, self.scene)
        out, cur = [], begin
        while remaining:
            options = [sw.apply(cur, self.scene) for sw in remaining]
            self.trials.evaluate(options)
            i = min(range(len(options)), key=lambda j: objective(self.trials.per(options[j])))
            out.append((remaining[i], options[i]))
            cur = options[i]
            del remaining[i]
        return out

    def gates_of(self, begin: Candidate, final: Candidate) -> dict[str, Gate]:
        """Per effect, whether final may be named as its cause (gates.py): the verdict's
        exact match of both, final's spread against begin's, FLIP before and after."""
        if (begin, final) in self.gated:
            return self.gated[begin, final]
        t = self.trials
        e0, e1 = t.exact_of(begin), t.exact_of(final)
        absorbed = absorbed_pixels(
            (e0, t.pairs[begin]),
            (e1, t.pairs[final]),
            lambda where: t.produced(final, where),
            t.target.values_judged,
        )

        def maps() -> tuple[F32, F32]:
            # Most often both are the maps of their FLIP means, computed while the search ran.
            return t.flip_map(begin), t.flip_map(final)

        self.gated[begin, final] = gates(e0, e1, absorbed, maps, t.target.masks)
        return self.gated[begin, final]

    def undo_effects(
        self, begin: Candidate, final: Candidate, sw: Switch
    ) -> tuple[set[str], set[str]]:
        """Effects whose matching pixels undoing `sw` would lose (more than the exact-match
        allowance and a tenth of what the final gained over the start, or the exact match
        itself: the final passes there and would not), and effects it would win back (more
        than the allowance)."""
        inverse = next(u for u in differences(final, begin, self.scene) if u.sets_same(sw))
        t = self.trials
        d0, d1 = t.exact_differing(begin), t.exact_differing(final)
        dw = t.exact_differing(inverse.apply(final, self.scene))
        lose = {
            k
            for k in d1
            if dw[k] - d1[k] > max(t.allowed(k), 0.1 * max(0, d0[k] - d1[k]))
            or d1[k] <= t.allowed(k) < dw[k]
        }
        win = {k for k in d1 if d1[k] - dw[k] > t.allowed(k)}
        return lose, win

    def justified(
        self, begin: Candidate, final: Candidate, or_more: bool
    ) -> tuple[Candidate, list[Step], list[Candidate]]:
        """The final without every switch that explains no effect that passes the gates
        (gates.py), and without every switch that makes some effect worse than the start;
        its steps from begin and the candidate after each: a cause is named only where the
        image shows it."""
        while True:
            self.trials.evaluate([final])
            passed = self.gates_of(begin, final)
            gained = {k for k, g in passed.items() if g.passed}
            worse = {k for k, g in passed.items() if g.worse}
            path = self.retell(begin, final)
            undo = {sw: self.undo_effects(begin, final, sw) for sw, _ in path}
            needs = self.joint_partial(final, {sw: lose & gained for sw, (lose, _) in undo.items()})
            drop = [sw for sw, eff in needs.items() if not eff]
            drop += [sw for sw in self.unconfirmed(final, needs, gained) if sw not in drop]
            culprits = [sw for sw, (_, win) in undo.items() if win & worse and sw not in drop]
            if worse and not culprits:  # together, not one by one: none of them is named
                culprits = [sw for sw in needs if sw not in drop]
            for sw in culprits:
                self.say(
                    f"diagnose: drop {sw.change(self.scene)}: it makes {', '.join(sorted(worse))} worse"
                )
            for sw in drop:
                self.say(f"diagnose: drop {sw.change(self.scene)}: it explains no effect")
            if not drop + culprits:
                # Judged once the rest is settled, the least followed first: a switch dropped
                # above (or one not yet dropped) must not leave its pixels to blame another.
                culprits = self.least_followed(final, begin, needs)
            if not drop + culprits:
                break
            final = undone(final, begin, drop + culprits, self.scene)
        return final, self._steps(begin, path, needs, or_more), [after for _, after in path]

    def unconfirmed(
        self, final: Candidate, needs: dict[Switch, set[str]], gained: set[str]
    ) -> list[Switch]:
        """Named mistakes that an effect they show in (mistakes.json) contradicts: it still
        differs in the final and is not explained. Their evidence is one effect of several (a
        normal turned inward blackens lit surfaces as a light direction turned round does, and
        also bends every mirror and glass ray): the image does not show that mistake."""
        exact = self.trials.exact_of(final).per_effect
        open_k = {k for k, e in exact.items() if not e.passed} - gained
        out = []
        for sw in needs:
            shows = (
                set(catalogue()[sw.key].effects) if sw.kind == "mistake" and sw.present else set()
            )
            if shows & open_k:
                self.say(
                    f"diagnose: drop {sw.change(self.scene)}: it also shows in "
                    f"{', '.join(sorted(shows & open_k))}, which it leaves unexplained"
                )
                out.append(sw)
        return out

    def least_followed(
        self, final: Candidate, begin: Candidate, needs: dict[Switch, set[str]]
    ) -> list[Switch]:
        """The switch the image follows least of those it does not follow (gates.followed),
        or none: undone from final, the render differs in pixels of the effects it explains
        that the image keeps otherwise. (Judged among all effects, a change would be blamed
        for what another mistake not yet found hides there: a BGR writer's glass.)"""
        t, out = self.trials, []
        exact = t.exact_of(final)
        for sw, explains in needs.items():
            if not explains:
                continue
            without = undone(final, begin, [sw], self.scene)
            t.exact_of(without)  # its bounds
            changed = changed_pixels(t.pairs[final], t.pairs[without], t.target.values_judged)
            masks = {k: m for k, m in t.target.masks.items() if k in explains}
            f = followed(changed, exact.matches, masks)
            # Where final's own renders disagree on CHAOS_RATIO times as many pixels of the
            # effect, what it does not follow is float rounding too (acne a float64 program
            # decides otherwise, in pixels where float32's perturbed renders agree).
            if (
                f is None
                or f.holds
                or exact.per_effect[f.effect].unstable >= CHAOS_RATIO * (f.changed - f.matched)
            ):
                continue
            out.append((f.matched / f.changed, sw, f))
        if not out:
            return []
        _, sw, f = min(out, key=lambda x: x[0])
        self.say(
            f"diagnose: drop {sw.change(self.scene)}: of the {f.changed:,} px of {f.effect} "
            f"it changes, the image shows the change in only {f.matched:,}"
        )
        return [sw]

    def joint_partial(
        self, final: Candidate, needs: dict[Switch, set[str]]
    ) -> dict[Switch, set[str]]:
        """needs without the effects that a hard-coded constant explains only together with
        another switch, and only in part (final does not match them exactly): a constant
        fitted on top of a change mimics a bug neither is (a hard-coded ior on top of a ray
        that never leaves glass). Quirks that together make another mode are not this."""
        exact = self.trials.exact_of(final).per_effect

        def joint(k: str) -> bool:
            sharing = [sw for sw, eff in needs.items() if k in eff]
            valued = any(sw.kind in VALUED for sw in sharing)
            return len(sharing) >= 2 and valued and not exact[k].passed

        dropped = {k for k in set().union(*needs.values()) if joint(k)}
        return {sw: eff - dropped for sw, eff in needs.items()}

    def _steps(
        self,
        begin: Candidate,
        path: list[tuple[Switch, Candidate]],
        needs: dict[Switch, set[str]],
        or_more: bool,
    ) -> list[Step]:
        steps, cur, per = [], begin, self.trials.per
        masks = self.trials.target.masks
        for sw, after in path:
            change = sw.change(self.scene, or_more=or_more)
            explains = tuple(k for k in masks if k in needs[sw])
            cause = sw.cause(or_more=or_more)
            before, now = per(cur), per(after)
            alike = self.alike(begin, path[-1][1], sw) if sw.kind in ALIKE_KINDS else []
            told, names = tuple(a[0] for a in alike), tuple(a[1] for a in alike)
            step = Step(change, cause, after.name, before, now, explains, sw.cause_kind, sw.step)
            steps.append(dataclasses.replace(step, alternatives=told, alternative_names=names))
            cur = after
        return steps

    def alike(self, begin: Candidate, final: Candidate, sw: Switch) -> list[tuple[str, str]]:
        """Constants (a depth, background, ior or bias) and named mistakes that, in place of
        the quirk toggle or mistake sw, give an image that fits the image at least as well as
        final's: all are said, since naming one alone could be false (a program with a deeper limit of its
        own is not -Q6; a light that blocks its own shadow rays and a light direction turned
        round both leave every lit surface black)."""
        without = undone(final, begin, [sw], self.scene)
        options = [
            o
            for o in switches(without, self.scene, (), full=True)
            if (o.kind in VALUED or (o.kind == "mistake" and o.present))
            and o != sw
            and not (o.kind == sw.kind == "mistake" and o.cause() == sw.cause())
        ]
        cands = [o.apply(without, self.scene) for o in options]
        t = self.trials
        t.evaluate(cands)
        # One that fits better still is said too: the search may have reached sw first (-Q6
        # before a deeper limit, which leaves fewer silhouette pixels differing).
        alike = [o for o, c in zip(options, cands, strict=True) if t.fits_as_well(c, final)]
        depths = sorted((o for o in alike if o.kind == "depth"), key=lambda o: int(o.key))
        # Depths that all fit are one finding: the shallowest, "or more" when the deepest fits.
        more = bool(depths) and int(depths[-1].key) == MAX_SEARCH_DEPTH and len(depths) > 1
        told = [(o.change(self.scene), o.cause()) for o in alike if o.kind != "depth"]
        if depths:
            d = depths[0]
            told.insert(0, (d.change(self.scene, or_more=more), d.cause(or_more=more)))
        return told

    def localised(self, final: Candidate, findings: dict[str, EffectFinding]) -> dict[str, Any]:
        """Where the pixels still differing from the result lie, by the result's path classes
        (localise.py): one extra render of the result, with the path AOV."""
        t = self.trials
        if all(f.matched for f in findings.values()):
            return {"overall": [], "effects": {}}
        paths = t.render.path_classes(final)
        if paths is None:
            return {"overall": [], "effects": {}}
        differing = ~t.exact_of(final).matches
        unexplained = [k for k, f in findings.items() if f.state == "unexplained"]
        return _located(paths, differing, t.target.masks, unexplained)

    def report(self, found: Found) -> tuple[dict[str, EffectFinding], str]:
        """Per effect: the exact match of the start and of the result, as the verdict judges
        a model (each rendered also with the camera turned), FLIP before and after, and the
        words."""
        self.say("diagnose: exact match and FLIP per effect for the start and the result")
        t, begin, final = self.trials, found.begin, found.result
        both = list(dict.fromkeys((begin, final)))
        for c in both:
            t.flip_soon(c)  # while the exact matches are made
        exact = {c: t.exact_of(c) for c in both}
        # FLIP alone (the judge's map, metrics.py), not evaluate_pair's SSIM and other maps.
        flip = {c: t.flip_means(c) for c in both}
        passed = self.gates_of(begin, final)
        findings = {}
        for k in EFFECTS:
            if k not in t.target.masks:
                continue
            ev = Evidence(
                exact[begin],
                exact[final],
                (flip[begin][k], flip[final][k]),
                (t.scores[begin].pixels[k], t.scores[final].pixels[k]),
                (len(t.scores), t.best_fixed(begin, k)),
                passed.get(k) if final != begin else None,
                _box(~exact[final].matches & t.target.masks[k]),
            )
            findings[k] = finding(k, found, ev)
        return findings, summary(found, findings, exact[begin])


# The switches whose named cause could be told as well by another (alike).
ALIKE_KINDS = ("quirk", "mistake", "effect")


def may_help(sw: Switch, still: set[str]) -> bool:
    """Whether sw can explain an effect still open: a named mistake is added only where one
    of the effects it shows in (mistakes.json) differs, a Fresnel curve where reflection or
    refraction does, a glass ior (and its fit, constant_fit.py) where refraction does, a
    background where the misses or what mirrors and glass show differ, a light's position
    where the direct light does; every other switch may."""
    if sw.kind == "fresnel" and sw.present:
        return bool({"reflection", "refraction"} & set(still))
    if sw.kind == "ior" and sw.present:
        return "refraction" in still
    if sw.kind == "background" and sw.present:
        return bool({"background", "reflection", "refraction"} & set(still))
    if sw.kind == "light" and sw.present:
        return "direct" in still
    if sw.kind == "colour" and sw.present:
        return bool({"direct", "reflection", "refraction"} & set(still))
    if sw.kind != "mistake" or not sw.present:
        return True
    return bool(set(catalogue()[sw.key].effects) & set(still))


def camera_mistakes() -> tuple[str, ...]:
    """The catalogue's mistakes of the camera step (mistakes.json), half_pixel_offset aside:
    it moves silhouettes by half a pixel, which the greedy search finds as any switch."""
    return tuple(
        m.name for m in catalogue().values() if m.step == "camera" and m.name != "half_pixel_offset"
    )


def _located(
    paths: INT, differing: BOOL, masks: dict[str, BOOL], effects: list[str]
) -> dict[str, Any]:
    """The localisation's record: the whole image's, and each effect's with its classes."""
    overall = localise.on_silhouettes(differing, masks.get("edges")) or localise.locate(
        differing, paths
    )
    per_effect = {}
    for k in effects:
        found = localise.locate(differing, paths, masks[k])
        if found is not None:
            classes = localise.classes(differing & masks[k], paths)
            per_effect[k] = {"step": found.step, "sentence": found.sentence, "classes": classes}
    return {"overall": [] if overall is None else [overall.as_dict()], "effects": per_effect}


def _box(where: BOOL) -> tuple[int, int, int, int] | None:
    """x0, y0, x1, y1 (inclusive) of the True pixels; None for none."""
    ys, xs = np.nonzero(where)
    if not len(ys):
        return None
    return int(xs.min()), int(ys.min()), int(xs.max()), int(ys.max())


def _starts(start: TargetModel | Candidate | None) -> list[Candidate]:
    """Where the search may begin: `start`, or the three modes."""
    if start is None:
        return [Candidate.of_mode(m) for m in MODES]
    return [start if isinstance(start, Candidate) else Candidate.from_model(start)]


@dataclass
class FunctionRenderer:
    """A Renderer around a plain function (what tests inject): no store, no costs known."""

    render: Callable[[TargetModel | Candidate], Image]
    turns: Sequence[tuple[float, float]] = ()
    grows: Sequence[int] = ()
    search_quirks: tuple[int, ...] = SEARCH_QUIRKS
    store: Store | None = None
    time_limit: float | None = None
    ray_budget: int | None = None
    # The path-class AOV of a candidate (localise.py); None: the diagnosis localises nothing.
    paths: Callable[[TargetModel | Candidate], INT | None] | None = None

    def __call__(self, what: TargetModel | Candidate) -> Image:
        return self.render(what)

    def passing(self, what: TargetModel | Candidate) -> Image:
        return self.render(what)

    def with_aovs(self, what: TargetModel | Candidate) -> Image:
        return self.render(what)

    def cost(self, what: TargetModel | Candidate) -> float:
        return 0.0

    def rays(self, what: TargetModel | Candidate) -> int:
        return 0

    def path_classes(self, what: TargetModel | Candidate) -> INT | None:
        return None if self.paths is None else self.paths(what)


@dataclass(frozen=True)
class DiagnoseOptions:
    """How one diagnosis runs. `start`: begin there instead of at the nearest of the three
    modes; `progress`: where the progress lines go; `parallel`: renders at once (the renderer
    must then be thread-safe); `max_renders`: no new full sweep of every switch starts past
    this many renders; `flip_seed`: a FLIP map of the image already computed (the verdict's:
    a render, the map against the image, where it holds), which the FLIP numbers start from."""

    start: TargetModel | Candidate | None = None
    progress: Callable[[str], None] | None = None
    parallel: int = 1
    max_renders: int = MAX_RENDERS
    flip_seed: FlipSeed | None = None


def diagnose(
    image: Image, scene: Scene, render: Renderer, options: DiagnoseOptions | None = None
) -> Diagnosis:
    """The nearest demo candidate to `image` (linear RGB as read by images.read_image) and
    the evidence per effect. `render` must return the candidate at the image's size with the
    id and depth AOVs (the first render's give the effect masks); its `turns` and `grows` are
    how exact matching perturbs a model, its `search_quirks` the quirks it can toggle, its
    `store` where FLIP numbers and diagnoses are kept (an image diagnosed before is not
    searched again, memo.py), and its `time_limit` is set from the start's cost and its
    `ray_budget` from the starts' rays (a candidate over either is skipped, and the diagnosis
    says so). When the switches that helped stop helping and some effect is still not
    reproduced, every switch is tried once more (while fewer than `max_renders` renders were
    made). Nothing depends on time but the skipped
    candidates, so a loaded machine gives the same diagnosis, later.
    An image without one finite pixel raises NoFinitePixels before any candidate is
    rendered."""
    o = options or DiagnoseOptions()
    t0 = time.perf_counter()
    check_finite(image)
    turns, grows, quirks, store = (
        list(render.turns),
        list(render.grows),
        render.search_quirks,
        render.store,
    )
    say = o.progress or (lambda _m: None)
    starts = _starts(o.start)
    name = None
    if store is not None:
        tries = {"quirks": quirks, "turns": turns, "grows": grows, "max_renders": o.max_renders}
        name = record_name(image, scene, starts, tries, store.identity)
        known = load(store, name, image, t0)
        if known is not None:
            say(f"diagnose: {known.result}, as an earlier search of {known.renders} renders found")
            return known
    trials = Trials(Target(image, scene), render, o.parallel, store)
    if o.flip_seed is not None:
        trials.flips.seed(o.flip_seed[0], image.rgb, o.flip_seed[1], o.flip_seed[2])
    try:
        found = Search(image, scene, trials, quirks, o.max_renders, say).run(starts)
    finally:
        trials.close()
    if store is not None and name is not None and not found.skipped:  # a later run may judge them
        keep(store, name, found)
    return found
