"""Renders diagnose candidates (and demo target models) with rtdemo at a given size, for
compare.judge.diagnose's injected `render`. Each render goes to a private temporary folder
that is removed when the renderer closes, errors included.

A candidate that changes a scene constant (the background, the glass spheres' ior) or turns
the camera (the sub-pixel renders exact matching needs, compare/render/models.py) is rendered
from a copy of the scene with that change, written beside the render and keyed by its bytes.

With `cache_dir`, renders are kept there under a content hash of the command (output path left
out), the (copied) scene file's bytes and the rtdemo binary's bytes (render/cache.py's key), so
the candidates a search tries for one student are read, not rendered, for the next: a class's
diagnoses share most of their renders. Cache files appear by atomic rename, so processes
sharing the folder (grade's process pool, Dask workers on one disk) never read a partial one."""

from __future__ import annotations

import hashlib
import itertools
import json
import os
import shlex
import shutil
import subprocess
import tempfile
import threading
from functools import cache
from pathlib import Path
from types import TracebackType

from compare.files import sha256_file
from compare.judge.candidate import Candidate
from compare.judge.diagnose import BASE_QUIRKS, LATER_QUIRKS
from compare.judge.images import Image, ImageError, read_image
from compare.judge.target_model import TargetModel
from compare.render.cache import renderer_identity
from compare.render.models import OFFSET_PIXELS, OFFSETS, SPHERE_ULPS, grown_scene, offset_scene
from compare.render.runner import ToolError, rtdemo_path
from scene_model.safe_paths import write_text_checked


def exact_turns() -> list[tuple[float, float]]:
    """The camera turns (in pixels) exact matching renders a model with, in the order of
    compare/render/models.py's render_offsets: the diagnosis judges its candidates so."""
    return [(dx * m, dy * m) for m in OFFSET_PIXELS for dx, dy in OFFSETS]


@cache
def _renders_quirks(executable: str, identity: str, scene_file: str, quirks: str) -> bool:
    """Whether this rtdemo build accepts `--quirk QUIRKS` (identity: the binary's hash, so a
    rebuilt rtdemo is asked again). A 1x1 render costs milliseconds."""
    with tempfile.TemporaryDirectory(prefix="rtval-probe-") as tmp:
        cmd = [executable, "render", scene_file, "-o", str(Path(tmp) / "p.exr"), "-q"]
        cmd += ["--width", "1", "--height", "1", "--mode", "physical", "--quirk", quirks]
        return subprocess.run(cmd, capture_output=True, check=False).returncode == 0


class CandidateRenderer:
    """`with CandidateRenderer(scene_file, w, h) as render: render(candidate) -> Image`."""

    def __init__(
        self,
        scene_file: str | Path,
        width: int,
        height: int,
        *,
        threads: int = 0,
        cache_dir: str | Path | None = None,
    ):
        self.scene_file = str(scene_file)
        self.width, self.height, self.threads = width, height, threads
        self.executable = rtdemo_path()
        self.cache_dir = Path(cache_dir) if cache_dir is not None else None
        self._dir: Path | None = None
        self._count = itertools.count()
        self._lock = threading.Lock()
        self._scene_hash = sha256_file(self.scene_file)
        # Every candidate asked for, by name (diagnose's steps name theirs), and cache use.
        self.seen: dict[str, Candidate] = {}
        self.rendered = 0
        self.cache_hits = 0
        self.turns = exact_turns()  # read by diagnose: how exact matching renders a model
        self.grows = list(SPHERE_ULPS)  # and its spheres grown and shrunk
        later = ",".join(f"Q{q}" for q in LATER_QUIRKS)
        known = _renders_quirks(
            self.executable, renderer_identity("rtdemo", self.executable), self.scene_file, later
        )
        self.search_quirks = BASE_QUIRKS + (LATER_QUIRKS if known else ())

    def __enter__(self) -> CandidateRenderer:
        self._dir = Path(tempfile.mkdtemp(prefix="rtval-diagnose-"))
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._dir is not None:
            shutil.rmtree(self._dir, ignore_errors=True)
            self._dir = None

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
        if c.ior is not None:
            for sphere in raw["spheres"]:
                if sphere.get("transparency", 0) > 0:
                    sphere["ior"] = c.ior
        return json.dumps(raw, indent=1)

    def _scene_for(self, c: Candidate) -> tuple[str, str]:
        """(scene file to render, its content hash): the scene, or a copy written once."""
        text = self.scene_text(c)
        if text is None:
            return self.scene_file, self._scene_hash
        digest = hashlib.sha256(text.encode()).hexdigest()
        folder = self.cache_dir if self.cache_dir is not None else self._dir
        assert folder is not None
        copy = folder / f"scene-{digest[:24]}.json"
        folder.mkdir(parents=True, exist_ok=True)
        write_text_checked(copy, text)  # checked, not trusted: a planted file or link is replaced
        return str(copy), digest

    def command(
        self, what: TargetModel | Candidate, out: str, scene: str | None = None
    ) -> list[str]:
        c = what if isinstance(what, Candidate) else Candidate.from_model(what)
        cmd = [self.executable, "render", scene or self.scene_file, "-o", out, "-q"]
        cmd += ["--width", str(self.width), "--height", str(self.height)]
        if self.threads:
            cmd += ["--threads", str(self.threads)]
        return cmd + c.rtdemo_args()

    def cache_file(
        self, what: TargetModel | Candidate, scene_hash: str | None = None
    ) -> Path | None:
        """Where the cache keeps this candidate's render (None without a cache)."""
        if self.cache_dir is None:
            return None
        c = what if isinstance(what, Candidate) else Candidate.from_model(what)
        if scene_hash is None:
            scene_hash = self._scene_for(c)[1]
        # --threads changes no pixel, so it is not part of the key.
        args = [f"{self.width}x{self.height}", *c.rtdemo_args()]
        h = hashlib.sha256(shlex.join(args).encode())
        h.update(scene_hash.encode())
        h.update(renderer_identity("rtdemo").encode())
        return self.cache_dir / f"candidate-{h.hexdigest()[:24]}.exr"

    def __call__(self, what: TargetModel | Candidate) -> Image:
        if self._dir is None:
            raise RuntimeError("CandidateRenderer used outside its `with` block")
        c = what if isinstance(what, Candidate) else Candidate.from_model(what)
        scene, scene_hash = self._scene_for(c)
        cached = self.cache_file(c, scene_hash)
        with self._lock:
            self.seen[c.name] = c
            n = next(self._count)
        if cached is not None and cached.is_file():
            try:
                image = read_image(cached)
                with self._lock:
                    self.cache_hits += 1
                return image
            except ImageError:  # damaged by hand or a full disk: render it again
                pass
        if cached is not None:
            cached.parent.mkdir(parents=True, exist_ok=True)
            # Beside its final name (one file system, so the rename is atomic), unique per
            # process and render.
            out = cached.with_name(
                f".{cached.stem}.{os.getpid()}.{threading.get_ident()}.{n}.partial.exr"
            )
        else:
            out = self._dir / f"c{n}.exr"
        cmd = self.command(c, str(out), scene)
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
            if proc.returncode != 0:
                raise ToolError(
                    f"rtdemo failed (exit {proc.returncode}) for {' '.join(cmd[1:])}: "
                    f"{proc.stderr.strip()[-1000:]}"
                )
            image = read_image(out)
            if cached is not None:
                out.replace(cached)
            with self._lock:
                self.rendered += 1
            return image
        finally:
            out.unlink(missing_ok=True)
