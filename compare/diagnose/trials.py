"""Every candidate the diagnosis (diagnose.py) tried: its score against the image
(diagnose_score.Target), the renders it keeps, and the exact matches (exact_match.py, as the
verdict judges a model) that its claims are made of.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from concurrent.futures import Future, ThreadPoolExecutor

import numpy as np

from compare.diagnose import kept as diagnose_kept
from compare.diagnose.candidate import Candidate
from compare.diagnose.flip import Flips, Means
from compare.diagnose.score import Codes, Renderer, Score, Store, Target
from compare.diagnose.transforms import Transform
from compare.judge.arrays import F32
from compare.judge.effects import BOOL
from compare.judge.exact_match import Bounds, ExactMatch, channel_matches, model_bounds
from compare.judge.images import Image
from compare.render.jobs import RenderLimit

# A candidate's render may take TIME_FACTOR times the dearest start's (a ray tree that doubles
# at every glass bounce runs for minutes), within these bounds in seconds: a loaded machine
# renders the start slowly too, and a 640x480 diagnosis must end within 30 s.
TIME_FACTOR = 40.0
TIME_LIMIT_MIN = 2.0
TIME_LIMIT_MAX = 8.0
# ... and may trace RAY_FACTOR times the rays of the dearest start (rtdemo render --ray-budget):
# the same bound counted in rays, which no machine load moves. On classic.json at 640x480 (the
# start 2.0e6 rays) the dearest candidate a search judges, depth 32 with acne (no_offset),
# traces 46 times the start's rays (9.2e7, 0.9 s on 2 threads); 100 times is about what the
# 2 s minimum time limit lets a render trace (~1e8 rays/s), while the tree that doubles at every
# glass bounce (no_inside_flip at depth 32) traces ~380000 times the start's (7.5e9 at 64x48).
RAY_FACTOR = 100


class Trials:
    """Every candidate the search tried, with its score against the target; the renders it
    keeps (for scoring again and for FLIP) and the exact matches claims are made of."""

    def __init__(
        self,
        target: Target,
        render: Renderer,
        parallel: int,
        store: Store | None = None,
    ) -> None:
        self.target, self.render, self.parallel = target, render, parallel
        self.turns, self.grows = list(render.turns), list(render.grows)
        self.skipped: dict[Candidate, str] = {}  # candidates over a limit: why
        self.values: Transform | None = None  # the writer's value transform (set_values)
        # One thread for the work a claim needs later (FLIP, exact matches), begun early.
        self.background = ThreadPoolExecutor(max_workers=1, thread_name_prefix="diagnose")
        self.store = store
        self.flips = Flips(store, self.background)
        self.scores: dict[Candidate, Score] = {}
        self.kept: dict[Candidate, Image] = {}
        self.keep: set[Candidate] = set()
        self.exact_memo: dict[Candidate, Future[ExactMatch]] = {}
        self.pairs: dict[Candidate, tuple[Bounds, Bounds]] = {}  # bounds of each exact match

    def _made(self, c: Candidate, *, passing: bool = False) -> Image:
        """c's render as the image's writer would have stored it: with the fitted value
        transform (set_values) applied, where there is one."""
        im = self.render.passing(c) if passing else self.render(c)
        if self.values is None:
            return im
        return dataclasses.replace(im, rgb=self.values.apply(im.rgb))

    def set_values(self, t: Transform) -> None:
        """Judge every render through t from now on (a writer's transform of the values):
        the kept renders are transformed and scored again, everything else dropped."""
        self.values = t
        self.kept = {c: dataclasses.replace(im, rgb=t.apply(im.rgb)) for c, im in self.kept.items()}
        self.scores = {c: self.target.score(im.rgb) for c, im in self.kept.items()}
        self.target.reference = None
        self.flips = Flips(self.store, self.background)

    def set_test(self, rgb: F32) -> None:
        """Judge against `rgb` from now on: every kept render is scored again, every other
        score is dropped."""
        self.target.set_test(rgb)
        self.scores = {c: self.target.score(im.rgb) for c, im in self.kept.items()}
        self.flips = Flips(self.store, self.background)  # FLIP against the image as it was

    def keep_only(self, keep: set[Candidate]) -> None:
        self.kept = {c: im for c, im in self.kept.items() if c in keep}
        self.keep = set(keep)

    def near(self, c: Candidate) -> None:
        """The candidates scored next are c's neighbours: count them against c's render
        (its codes where the store kept them, else its render, read again unless kept)."""
        codes = None if c in self.kept else self._kept_codes(c)[1]
        if codes is not None:
            self.target.use_reference_codes(codes)
        else:
            self.target.use_reference(self.centre_once(c).rgb)

    def centre_once(self, c: Candidate) -> Image:
        """c's render at pixel centres, kept or rendered (not kept for later)."""
        return self.kept[c] if c in self.kept else self._made(c)

    def evaluate(self, cands: Sequence[Candidate]) -> None:
        todo = [c for c in dict.fromkeys(cands) if c not in self.scores]
        if not todo:
            return
        # The deepest first: a deep limit can cost a hundred shallow renders (a chain of glass
        # with acne), and started last it would leave the other threads idle at the end.
        todo.sort(key=lambda c: -c.depth(self.target.scene))
        if self.target.regions is None:  # the first render's AOVs give them: judged alone
            self._keep(todo[0], *self._judged(todo.pop(0)))
        with ThreadPoolExecutor(max_workers=max(1, self.parallel)) as pool:
            # Each thread renders and scores (numpy lets go of the GIL), and a render not
            # kept is dropped once scored: a round's renders are never all in memory at once.
            for c, judged in zip(todo, pool.map(self._judged, todo), strict=True):
                self._keep(c, *judged)

    def _judged(self, c: Candidate) -> tuple[Image | None, Score]:
        """c's score (from its codes where the store kept them), and its render when it is
        to be kept."""
        t = self.target
        name, codes = self._kept_codes(c)
        if codes is not None and c not in self.keep:
            return None, t.score_codes(codes)
        # A render only scored, its codes kept: the renderer need not keep it (passing).
        passing = name is not None and c not in self.keep
        try:
            im = self._made(c, passing=passing)
        except RenderLimit as e:  # its time limit or its ray budget
            return None, self.skip(c, str(e))
        if t.regions is None:
            self._first_check(c, im)
        else:
            t.check(c, im)
        if codes is None:
            codes = t.codes_of(im.rgb)
            if name is not None:
                diagnose_kept.write(self.store, name, diagnose_kept.pack_codes(codes))
        return (im if c in self.keep else None), t.score_codes(codes)

    def _kept_codes(self, c: Candidate) -> tuple[str | None, Codes | None]:
        """Where c's codes are kept (None: they are not, for a float image or no store) and
        the codes read back from there (None: absent or damaged)."""
        t = self.target
        if t.regions is None or t.values_judged or self.store is None:
            return None, None
        name = self._kept_name("codes", c, *t.codes_kind())
        pixels = t.total_pixels_ordered()
        data = diagnose_kept.read(self.store, name, diagnose_kept.codes_size(pixels))
        return name, diagnose_kept.unpack_codes(data, pixels)

    def skip(self, c: Candidate, why: str) -> Score:
        """c ran past the time limit or the ray budget: it is skipped (said in the diagnosis), scored as far
        from the image as any render can be, so that no step keeps it."""
        self.skipped[c] = why
        regions = self.target.regions
        assert regions is not None
        whole = {k: int(n) for k, n in zip(regions.names, regions.counts, strict=True)}
        worst = dict.fromkeys(whole, 255.0)
        return Score(whole, dict.fromkeys(whole, 1.0), worst, worst, b"skipped:" + c.name.encode())

    def limit_time(self, starts: Sequence[Candidate]) -> float | None:
        """Sets the renderer's time limit from what the starts' renders cost (TIME_FACTOR
        times the dearest, within TIME_LIMIT_MIN and TIME_LIMIT_MAX); TIME_LIMIT_MAX when no
        cost is known (the starts' codes were read from derived/, kept by a classmate's
        diagnosis, and nothing was rendered), so that no candidate ever runs unbounded."""
        cost = max((self.render.cost(c) for c in starts), default=0.0)
        limit = min(TIME_LIMIT_MAX, max(TIME_LIMIT_MIN, TIME_FACTOR * cost))
        if cost <= 0:
            limit = TIME_LIMIT_MAX
        self.render.time_limit = limit
        return limit

    def limit_rays(self, starts: Sequence[Candidate]) -> int | None:
        """Sets the renderer's ray budget: RAY_FACTOR times the rays of the dearest start.
        None (no budget; the time limit still bounds every candidate) when no start's rays
        are known (their codes were read from derived/ and nothing was rendered)."""
        rays = max((self.render.rays(c) for c in starts), default=0)
        budget = RAY_FACTOR * rays if rays > 0 else None
        self.render.ray_budget = budget
        return budget

    def _with_aovs(self, c: Candidate, im: Image) -> Image:
        """c's render with the AOVs the first check needs: `im`, or rendered again with them
        by a renderer that leaves them out of some renders (CandidateRenderer)."""
        if "id" in im.aovs and "depth" in im.aovs:
            return im
        return self.render.with_aovs(c)

    def _first_check(self, c: Candidate, im: Image) -> None:
        """The first render sets the effect masks: the ones kept for it, or found (and kept)."""
        name, shape = self._kept_name("masks", c), im.rgb.shape[:2]
        data = diagnose_kept.read(self.store, name, diagnose_kept.masks_size(shape))
        masks = diagnose_kept.unpack_masks(data, shape)
        self.target.check(c, im if masks is not None else self._with_aovs(c, im), masks)
        if masks is None:
            diagnose_kept.write(self.store, name, diagnose_kept.pack_masks(self.target.masks))

    def _keep(self, c: Candidate, im: Image | None, score: Score) -> None:
        self.scores[c] = score
        if im is not None:
            self.kept[c] = im

    def render_all(self, cands: Sequence[Candidate]) -> list[Image]:
        with ThreadPoolExecutor(max_workers=max(1, self.parallel)) as pool:
            return list(pool.map(self._made, cands))

    def centre(self, c: Candidate) -> Image:
        """c's render at pixel centres (kept, or rendered again: the cache has it)."""
        if c not in self.kept:
            self.kept[c] = self._made(c)
        return self.kept[c]

    def flip_soon(self, c: Candidate) -> None:
        """Start c's FLIP means in the background (the search goes on meanwhile)."""
        t = self.target
        self.flips.start(c, self.centre(c).rgb, t.test, t.masks)

    def flip_guess(self, c: Candidate) -> None:
        """Start c's FLIP means as the likely result's (a later guess replaces it unless
        it has begun)."""
        t = self.target
        self.flips.guess(c, self.centre(c).rgb, t.test, t.masks)

    def flip_means(self, c: Candidate) -> Means:
        """Mean FLIP of the image against c's centre render, per effect region."""
        t = self.target
        return self.flips.means(c, self.centre(c).rgb, t.test, t.masks)

    def flip_map(self, c: Candidate) -> F32:
        """The LDR-FLIP map of the image against c's centre render (metrics.flip_ldr_map's
        values): the one its FLIP means came from, else computed from the first map."""
        return self.flips.map_of(c, self.centre(c).rgb, self.target.test)

    def exact_of(self, c: Candidate) -> ExactMatch:
        """The verdict's own judging (exact_match.py) of the image against the candidate,
        rendered at pixel centres, with the camera turned by each turn and its spheres grown
        by each growth: the perturbed renders the verdict judges with."""
        if c not in self.exact_memo:
            done: Future[ExactMatch] = Future()
            done.set_result(self._exact(c))
            self.exact_memo[c] = done
        return self.exact_memo[c].result()

    def exact_soon(self, c: Candidate) -> None:
        """Begin c's exact match in the background (the search goes on meanwhile)."""
        if c not in self.exact_memo:
            self.exact_memo[c] = self.background.submit(self._exact, c)

    def _perturbed(self, c: Candidate) -> list[Candidate]:
        return [c.turned(t) for t in self.turns] + [c.grown(g) for g in self.grows]

    def produced(self, c: Candidate, where: BOOL) -> BOOL:
        """H x W: pixels of `where` whose value in the image one of c's renders (centre or
        perturbed) stores by itself, not only the interval between them
        (gates.absorbed_pixels); False elsewhere."""
        t = self.target
        out: BOOL = np.zeros(t.test.shape[:2], bool)
        test = t.test[where]
        found = np.zeros(len(test), bool)
        for im in self.render_all([c, *self._perturbed(c)]):
            found |= channel_matches(im.rgb[where], test, t.image.encoding)
        out[where] = found
        return out

    def _exact(self, c: Candidate) -> ExactMatch:
        """c's exact match from its bounds: kept in the store, or computed from its renders
        (only then read)."""
        encoding = self.target.image.encoding
        perturbed = self._perturbed(c)
        name = self._kept_name("bounds", c, self.turns, self.grows, encoding)
        shape = self.target.image.rgb.shape
        data = diagnose_kept.read(self.store, name, diagnose_kept.bounds_size(shape))
        pair = diagnose_kept.unpack_bounds(data, shape)
        if pair is None:
            renders = [im.rgb for im in self.render_all([c, *perturbed])]
            pair = model_bounds(renders, encoding)
            diagnose_kept.write(self.store, name, diagnose_kept.pack_bounds(pair))
        self.pairs[c] = pair
        return self.target.exact(c, pair, 1 + len(perturbed))

    def _kept_name(self, kind: str, c: Candidate, *more: object) -> str:
        values = self.values.name if self.values is not None else ""
        identity = self.store.identity if self.store else ""
        return diagnose_kept.kept_name(kind, identity, c, values, *more)

    def close(self) -> None:
        """Waits for the background work still running (a start the search left behind)."""
        self.background.shutdown(wait=True, cancel_futures=True)

    def exact_differing(self, c: Candidate) -> dict[str, int]:
        return {k: e.differing for k, e in self.exact_of(c).per_effect.items()}

    def per(self, c: Candidate) -> dict[str, float]:
        return self.scores[c].per_effect()

    def differing(self, c: Candidate) -> dict[str, int]:
        return self.scores[c].differing

    def whole_differing(self, c: Candidate) -> int:
        """Pixels of the whole image (every effect) that differ from the candidate."""
        return sum(self.scores[c].differing.values())

    def whole(self, c: Candidate) -> float:
        """The distance of the whole image: each effect weighted by its pixels."""
        regions = self.target.regions
        assert regions is not None
        per = self.per(c)
        return float(sum(per[k] * n for k, n in zip(regions.names, regions.counts, strict=True)))

    def total_pixels(self) -> int:
        assert self.target.regions is not None
        return int(self.target.regions.counts.sum())

    def allowed(self, effect: str) -> int:
        """Differing pixels an exact match allows in this effect (as exact_match says)."""
        return self.target.allowance[effect]

    def open_effects(self, c: Candidate) -> set[str]:
        """Effects with more pixels differing from the candidate's centre render than an exact
        match allows."""
        return {k for k, n in self.scores[c].differing.items() if n > self.allowed(k)}

    def matched(self, c: Candidate) -> bool:
        """Every effect within the exact-match allowance of the candidate's centre render."""
        return not self.open_effects(c)

    def fits_as_well(self, a: Candidate, b: Candidate) -> bool:
        """a leaves no more pixels of any effect differing than b, up to the exact-match
        allowance (both scored): the image cannot tell them apart."""
        da, db = self.differing(a), self.differing(b)
        return all(da[k] <= db[k] + self.allowed(k) for k in da)

    def best_fixed(self, begin: Candidate, effect: str) -> float:
        """The largest share of begin's differing pixels in `effect` that a candidate tried
        makes match (pixel-centre renders) without more pixels of the whole image differing
        than begin's: how near the search came."""
        d0 = self.differing(begin)[effect]
        if not d0:
            return 1.0
        limit = self.whole_differing(begin)
        return max(
            0.0,
            *(
                1 - sc.differing[effect] / d0
                for sc in self.scores.values()
                if sum(sc.differing.values()) <= limit
            ),
        )
