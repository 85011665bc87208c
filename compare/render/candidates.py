"""Renders diagnose candidates (and demo target models) with rtdemo at a given size, for
compare.judge.diagnose's injected `render`. Each render goes to a private temporary folder
that is removed when the renderer closes, errors included."""

from __future__ import annotations

import itertools
import shutil
import subprocess
import tempfile
import threading
from pathlib import Path
from types import TracebackType

from compare.judge.candidate import Candidate
from compare.judge.images import Image, read_image
from compare.judge.target_model import TargetModel
from compare.render.runner import ToolError, rtdemo_path


class CandidateRenderer:
    """`with CandidateRenderer(scene_file, w, h) as render: render(candidate) -> Image`."""

    def __init__(self, scene_file: str | Path, width: int, height: int, *, threads: int = 0):
        self.scene_file = str(scene_file)
        self.width, self.height, self.threads = width, height, threads
        self.executable = rtdemo_path()
        self._dir: Path | None = None
        self._count = itertools.count()
        self._lock = threading.Lock()

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

    def __call__(self, what: TargetModel | Candidate) -> Image:
        if self._dir is None:
            raise RuntimeError("CandidateRenderer used outside its `with` block")
        with self._lock:
            out = self._dir / f"c{next(self._count)}.exr"
        cmd = self.command(what, str(out))
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
            if proc.returncode != 0:
                raise ToolError(
                    f"rtdemo failed (exit {proc.returncode}) for {' '.join(cmd[1:])}: "
                    f"{proc.stderr.strip()[-1000:]}"
                )
            return read_image(out)
        finally:
            out.unlink(missing_ok=True)
