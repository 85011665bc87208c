"""Renders diagnose candidates (and demo target models) with rtdemo at a given size, for
compare.judge.diagnose's injected `render`. Each render goes to a private temporary folder
that is removed when the renderer closes, errors included.

With `cache_dir`, renders are kept there under a content hash of the command (output path left
out), the scene file's bytes and the rtdemo binary's bytes (render/cache.py's key), so the
candidates a search tries for one student are read, not rendered, for the next: a class's
diagnoses share most of their renders. Cache files appear by atomic rename, so processes
sharing the folder (grade's process pool, Dask workers on one disk) never read a partial one."""

from __future__ import annotations

import hashlib
import itertools
import os
import shlex
import shutil
import subprocess
import tempfile
import threading
from pathlib import Path
from types import TracebackType

from compare.files import sha256_file
from compare.judge.candidate import Candidate
from compare.judge.images import Image, ImageError, read_image
from compare.judge.target_model import TargetModel
from compare.render.cache import renderer_identity
from compare.render.runner import ToolError, rtdemo_path


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
        self._scene_hash = sha256_file(self.scene_file) if self.cache_dir else ""
        # Every candidate asked for, by name (diagnose's steps name theirs), and cache use.
        self.seen: dict[str, Candidate] = {}
        self.rendered = 0
        self.cache_hits = 0

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

    def command(self, what: TargetModel | Candidate, out: str) -> list[str]:
        c = what if isinstance(what, Candidate) else Candidate.from_model(what)
        cmd = [self.executable, "render", self.scene_file, "-o", out, "-q"]
        cmd += ["--width", str(self.width), "--height", str(self.height)]
        if self.threads:
            cmd += ["--threads", str(self.threads)]
        return cmd + c.rtdemo_args()

    def cache_file(self, what: TargetModel | Candidate) -> Path | None:
        """Where the cache keeps this candidate's render (None without a cache)."""
        if self.cache_dir is None:
            return None
        c = what if isinstance(what, Candidate) else Candidate.from_model(what)
        # --threads changes no pixel, so it is not part of the key.
        args = [f"{self.width}x{self.height}", *c.rtdemo_args()]
        h = hashlib.sha256(shlex.join(args).encode())
        h.update(self._scene_hash.encode())
        h.update(renderer_identity("rtdemo").encode())
        return self.cache_dir / f"candidate-{h.hexdigest()[:24]}.exr"

    def __call__(self, what: TargetModel | Candidate) -> Image:
        if self._dir is None:
            raise RuntimeError("CandidateRenderer used outside its `with` block")
        c = what if isinstance(what, Candidate) else Candidate.from_model(what)
        cached = self.cache_file(c)
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
        cmd = self.command(c, str(out))
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
