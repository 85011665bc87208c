"""Renders diagnose candidates (and demo target models) with rtdemo at a given size, for
compare.diagnose.search's injected `render`, through the render cache every command shares
(cache.py, jobs.py): a candidate is a RenderJob, the command a person could type, keyed by
render_key and stored by the cache's atomic insert, so the candidates a search tries for one
student are read, not rendered, for the next (a class's diagnoses share most of their renders),
and a plain demo model's render is the one `grade` and `report` use.

A candidate that changes a scene constant (the background, the glass spheres' ior) or turns
the camera (the sub-pixel renders exact matching needs, compare/render/models.py) is rendered
from a copy of the scene with that change, kept in the cache's derived/ and named by its bytes.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import threading
from collections import OrderedDict
from functools import cache
from pathlib import Path
from types import TracebackType

import numpy as np
from numpy.typing import NDArray

from compare.diagnose.candidate import Candidate
from compare.diagnose.search import BASE_QUIRKS, LATER_QUIRKS
from compare.errors import ToolError
from compare.judge.images import Image, ImageError, read_image
from compare.judge.target_model import TargetModel
from compare.render import models
from compare.render.cache import RenderCache, renderer_identity
from compare.render.jobs import RenderJob, read_passing, render_one, set_key
from compare.render.models import OFFSET_PIXELS, OFFSETS, SPHERE_ULPS, grown_scene, offset_scene
from compare.render.runner import rtdemo_path
from safe_files.content import sha256_file
from safe_files.paths import read_bounded, write_atomic

STORE_MAX_BYTES = 1 << 20


def exact_turns() -> list[tuple[float, float]]:
    """The camera turns (in pixels) exact matching renders a model with, in the order of
    compare/render/models.py's render_offsets: the diagnosis judges its candidates so."""
    return [(dx * m, dy * m) for m in OFFSET_PIXELS for dx, dy in OFFSETS]


def is_plain_model(c: Candidate) -> bool:
    """Whether c is a demo model as it is (no switch, scene change, turn or growth): rendered
    by models.model_job's command."""
    return c == Candidate.from_model(c.model)


def candidate_job(
    c: Candidate, scene_file: str | Path, width: int, height: int, *, aovs: bool = False
) -> RenderJob:
    """The render command of `c` on `scene_file` (the scene, or its copy with c's changes);
    for a plain demo model it is models.model_job's command, so both share one cache entry.
    Any other candidate is rendered without AOVs unless asked (`aovs`): the search judges
    its colour alone, and the EXR is then 3 channels of 8."""
    size = ["--width", str(width), "--height", str(height)]
    channels = [] if aovs or is_plain_model(c) else ["--exr-channels", "rgb"]
    return RenderJob(
        "candidate",
        c.name,
        "rtdemo",
        ["render", "{scene}", "-o", "{out}", "-q", *c.rtdemo_args(), *size, *channels],
        "diagnose candidate",
        scene=str(scene_file),
    )


@cache
def _renders_quirks(root: str, identity: str, scene_file: str, quirks: str) -> bool:
    """Whether this rtdemo build accepts `--quirk QUIRKS` (identity: the binary's hash, so a
    rebuilt rtdemo is asked again): a 1x1 render, cached like any other."""
    probe = ["--mode", "physical", "--quirk", quirks]
    job = RenderJob(
        "probe",
        f"--quirk {quirks} probe",
        "rtdemo",
        ["render", "{scene}", "-o", "{out}", "-q", "--width", "1", "--height", "1", *probe],
        "probe",
        scene=scene_file,
    )
    try:
        render_one(job, RenderCache(root))
    except ToolError:
        return False
    return True


class _Recent:
    """The renders this process read last, by cache key, up to MEMORY_BYTES: the searches
    of one process (a grading worker's students) ask for the same candidates, and one search
    asks for some again (its references, its evidence pictures). Kept without the AOVs no
    search reads (read_image's `aovs`)."""

    def __init__(self, limit: int) -> None:
        self.limit, self.used = limit, 0
        self.images: OrderedDict[str, Image] = OrderedDict()
        self.lock = threading.Lock()

    def get(self, key: str) -> Image | None:
        with self.lock:
            image = self.images.get(key)
            if image is not None:
                self.images.move_to_end(key)
            return image

    def put(self, key: str, kept: Image) -> Image:
        size = kept.rgb.nbytes + sum(v.nbytes for v in kept.aovs.values())
        with self.lock:
            if key not in self.images and size <= self.limit:
                self.images[key] = kept
                self.used += size
            while self.used > self.limit:
                _, old = self.images.popitem(last=False)
                self.used -= old.rgb.nbytes + sum(v.nbytes for v in old.aovs.values())
        return kept


MEMORY_BYTES = 512 * 2**20  # a 640x480 search's renders, twice over
KEPT_AOVS = ("id", "depth")  # the effect masks' (diagnose_score.Target.check)
_RECENT = _Recent(MEMORY_BYTES)


def forget_recent() -> None:
    """Read every render from the cache again (what this process read before is dropped)."""
    with _RECENT.lock:
        _RECENT.images.clear()
        _RECENT.used = 0


class DerivedStore:
    """diagnose's Store in the render cache's derived/ (names carry their inputs' hashes):
    a file that is not a regular one, or that cannot be read, counts as absent."""

    def __init__(self, cache: RenderCache, identity: str) -> None:
        self.cache, self.identity = cache, identity

    def get(self, name: str) -> str | None:
        try:
            return read_bounded(self.cache.derived(name), STORE_MAX_BYTES).decode()
        except (OSError, UnicodeDecodeError):
            return None

    def put(self, name: str, text: str) -> None:
        write_atomic(self.cache.derived(name), text)

    def get_bytes(self, name: str, max_bytes: int) -> bytes | None:
        try:
            return read_bounded(self.cache.derived(name), max_bytes)
        except OSError:
            return None

    def put_bytes(self, name: str, data: bytes) -> None:
        # Not synced: what a crash tears fails the sha1 its reader checks (diagnose_kept).
        write_atomic(self.cache.derived(name), data, durable=False)


class CandidateRenderer:
    """`with CandidateRenderer(scene_file, w, h) as render: render(candidate) -> Image`.
    `cache`: the render cache (a folder, or by default the one every command shares); on
    leaving, its counts are added and it is evicted to its cap once."""

    def __init__(
        self,
        scene_file: str | Path,
        width: int,
        height: int,
        *,
        threads: int = 0,
        cache: RenderCache | str | Path | None = None,
    ):
        self.scene_file = str(scene_file)
        self.width, self.height, self.threads = width, height, threads
        self.cache = cache if isinstance(cache, RenderCache) else RenderCache(cache)
        # Read by diagnose: where its FLIP numbers and diagnoses are kept, and for what.
        self.store = DerivedStore(self.cache, self._identity())
        self._open = False
        self._lock = threading.Lock()
        # Every candidate asked for, by name (diagnose's steps name theirs), and cache use.
        self.seen: dict[str, Candidate] = {}
        self.rendered = 0
        self.cache_hits = 0  # renders not made: read from the cache, or from memory
        self.memory_hits = 0  # ... the renders this process had read already (_RECENT)
        # Seconds a candidate's render may take (diagnose sets it from the start's cost; None:
        # no limit), and what each render took, by candidate name.
        self.time_limit: float | None = None
        self.costs: dict[str, float] = {}
        # Rays a candidate's render may trace (diagnose sets it from the starts' rays; None: no
        # limit), and the rays each render traced (its EXR header), by candidate name.
        self.ray_budget: int | None = None
        self.ray_counts: dict[str, int] = {}
        self.turns = exact_turns()  # read by diagnose: how exact matching renders a model
        self.grows = list(SPHERE_ULPS)  # and its spheres grown and shrunk
        later = ",".join(f"Q{q}" for q in LATER_QUIRKS)
        identity = renderer_identity("rtdemo", rtdemo_path())
        known = _renders_quirks(str(self.cache.root), identity, self.scene_file, later)
        self.search_quirks = BASE_QUIRKS + (LATER_QUIRKS if known else ())

    def _identity(self) -> str:
        """What every render of this renderer depends on: rtdemo's binary and RTDEMO_*
        environment, the scene file, the size, and the code that makes the commands and the
        scene copies (this module and models.py)."""
        h = hashlib.sha256(renderer_identity("rtdemo", rtdemo_path()).encode())
        env = sorted((k, v) for k, v in os.environ.items() if k.startswith("RTDEMO_"))
        h.update(json.dumps([env, self.width, self.height, sha256_file(self.scene_file)]).encode())
        for module in (sys.modules[__name__], models):
            h.update(Path(module.__file__ or "").read_bytes())
        return h.hexdigest()

    def __enter__(self) -> CandidateRenderer:
        self._open = True
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self._open = False
        self.cache.count(hits=self.cache_hits - self.memory_hits, misses=self.rendered)
        if self.rendered:
            self.cache.evict()  # what this search just used is within the grace period

    def scene_text(self, c: Candidate) -> str | None:
        """The JSON of the scene copy `c` is rendered from; None: the scene file itself."""
        if c.turn is None and c.grow is None and not c.scene_changes():
            return None
        if c.turn is not None:
            text = offset_scene(Path(self.scene_file), (self.width, self.height), *c.turn)
        elif c.grow is not None:
            text = grown_scene(Path(self.scene_file), c.grow)
        else:
            text = Path(self.scene_file).read_text(encoding="utf-8-sig")
        raw = json.loads(text)
        if c.background is not None:
            raw["background"] = list(c.background)
        if c.bias is not None:
            raw["bias"] = c.bias
        if c.ior is not None:
            for sphere in raw["spheres"]:
                if sphere.get("transparency", 0) > 0 and c.ior_sphere in (None, sphere.get("name")):
                    sphere["ior"] = c.ior
        raw["camera"].update(c.scene_changes().get("camera", {}))
        if c.colour is not None:
            for sphere in raw["spheres"]:
                if sphere.get("name") == c.colour[0]:
                    sphere["color"] = list(c.colour[1])
        if c.light is not None:  # the scene's one light (light_fit.py offers no other)
            for sphere in raw["spheres"]:
                if any(v > 0 for v in sphere.get("emission", [0, 0, 0])):
                    sphere["center"] = list(c.light)
        return json.dumps(raw, indent=1)

    def _scene_for(self, c: Candidate) -> str:
        """The scene file to render c from: the scene, or a copy in the cache's derived/
        (checked, not trusted: a planted file or link there is replaced)."""
        text = self.scene_text(c)
        if text is None:
            return self.scene_file
        digest = hashlib.sha256(text.encode()).hexdigest()[:24]
        return str(self.cache.derived_text(f"scene-{digest}-candidate.json", text))

    def job(self, what: TargetModel | Candidate, *, aovs: bool = False) -> RenderJob:
        c = what if isinstance(what, Candidate) else Candidate.from_model(what)
        job = candidate_job(c, self._scene_for(c), self.width, self.height, aovs=aovs)
        job.time_limit = self.time_limit
        job.ray_budget = self.ray_budget
        return job

    def cost(self, what: TargetModel | Candidate) -> float:
        """Seconds the render of `what` took when it was made (0 when not known)."""
        c = what if isinstance(what, Candidate) else Candidate.from_model(what)
        with self._lock:
            return self.costs.get(c.name, 0.0)

    def _cost(self, c: Candidate, job: RenderJob) -> None:
        seconds = job.seconds or float(job.info.get("seconds", 0.0) or 0.0)
        with self._lock:
            self.costs[c.name] = seconds

    def rays(self, what: TargetModel | Candidate) -> int:
        """Rays its render traced (camera, secondary and shadow; 0 when not known)."""
        c = what if isinstance(what, Candidate) else Candidate.from_model(what)
        with self._lock:
            return self.ray_counts.get(c.name, 0)

    def _rays(self, c: Candidate, image: Image) -> Image:
        """Keeps the rays of c's render from its EXR header (rtdemo writes them there)."""
        keys = ("rtval.rays_camera", "rtval.rays_secondary", "rtval.rays_shadow")
        if all(k in image.header for k in keys):
            with self._lock:
                self.ray_counts[c.name] = sum(int(image.header[k]) for k in keys)
        return image

    def with_aovs(self, what: TargetModel | Candidate) -> Image:
        """The render with its id and depth AOVs (read by diagnose for the effect masks)."""
        return self(what, aovs=True)

    def passing(self, what: TargetModel | Candidate) -> Image:
        """The candidate's render for a search that scores it once and keeps its codes: read
        from memory or the cache where it is there, else made and read without being stored
        (jobs.read_passing) nor held in memory. Asked for again (a search's result), it is
        made again and stored: a later search of the program reads it."""
        c = self._seen(what)
        job = self.job(c)
        recent = _RECENT.get(set_key(job))
        if recent is not None:
            self._count(hit=True, memory=True)
            return recent
        try:
            image, hit = read_passing(
                job, self.cache, lambda p: read_image(p, aovs=KEPT_AOVS), extra_args=self._extra()
            )
        except ImageError:  # a cached entry whole by its sha256 but unreadable: made again
            return self(c)
        self._count(hit=hit)
        self._cost(c, job)
        return self._rays(c, image)

    def path_classes(self, what: TargetModel | Candidate) -> NDArray[np.int64] | None:
        """The candidate's path-class AOV (rtdemo --exr-channels rgb+path; localise.py): one
        render, cached like the others. None when this rtdemo cannot write it (an older
        build) or the render fails: the diagnosis then localises nothing."""
        c = self._seen(what)
        job = self.job(c)
        job.key, job.label = f"{job.key}-path", f"{job.label} (path classes)"
        job.args = [a for a in job.args if a not in ("--exr-channels", "rgb")]
        job.args += ["--exr-channels", "rgb+path"]
        try:
            hit = render_one(job, self.cache, extra_args=self._extra())
            image = read_image(job.exr(self.cache), aovs=("path",))
        except (ToolError, ImageError):
            return None
        self._count(hit=hit)
        path = image.aovs.get("path")
        return None if path is None else path.astype(np.int64)

    def _seen(self, what: TargetModel | Candidate) -> Candidate:
        if not self._open:
            raise RuntimeError("CandidateRenderer used outside its `with` block")
        c = what if isinstance(what, Candidate) else Candidate.from_model(what)
        with self._lock:
            self.seen[c.name] = c
        return c

    def _extra(self) -> list[str]:
        """rtdemo's arguments that change no pixel (kept out of the cache key)."""
        return ["--threads", str(self.threads)] if self.threads else []

    def _count(self, *, hit: bool, memory: bool = False) -> None:
        with self._lock:
            self.cache_hits += hit
            self.memory_hits += memory
            self.rendered += not hit

    def __call__(self, what: TargetModel | Candidate, *, aovs: bool = False) -> Image:
        """The candidate's render; its AOVs only where it is a plain model or `aovs`."""
        c = self._seen(what)
        job = self.job(c, aovs=aovs)
        recent = _RECENT.get(set_key(job))
        if recent is not None:  # read already by this process: the cache is not asked
            self._count(hit=True, memory=True)
            return self._rays(c, recent)
        extra = self._extra()
        hit = render_one(job, self.cache, extra_args=extra)
        self._cost(c, job)
        try:
            image = read_image(job.exr(self.cache), aovs=KEPT_AOVS)
        except ImageError:  # whole by its sha256 but unreadable: render it again
            hit = render_one(job, self.cache, extra_args=extra, again=True)
            image = read_image(job.exr(self.cache), aovs=KEPT_AOVS)
        self._count(hit=hit)
        return self._rays(c, _RECENT.put(job.cache_key, image))
