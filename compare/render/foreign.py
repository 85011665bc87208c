"""Running any renderer from a command template, one scene at a time.

The template is split like a shell would (shlex) but run without one; each word may hold
placeholders: {scene} (the scene JSON), {scene_xml} (its Mitsuba XML export, written only when
asked for), {out} (the image to write), {width}, {height}, {spp} and {mode}. The process runs in
its own process group, so a time limit kills whatever it started too.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import re
import shlex
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from compare.judge.images import Image, ImageError, read_image
from compare.render.foreign_sandboxed import SandboxedRenderFailed, render_sandboxed
from compare.render.placeholders import PLACEHOLDER, fill
from compare.student_ids import displayable
from mitsuba_ref.export import ExportOptions, export_scene
from scene_model.scene import Scene

PLACEHOLDERS = ("scene", "scene_xml", "out", "width", "height", "spp", "mode")
OUTPUT_FORMATS = ("exr", "pfm", "png", "ppm")
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,63}")
_INTERPRETERS = re.compile(r"(python[0-9.]*|pypy[0-9.]*|node|ruby|perl|julia|java|bash|sh|env)")
STDERR_KEPT = 2000  # characters of the renderer's stderr kept for a failure message


class RenderFailed(RuntimeError):
    """The renderer ran but gave no usable image; the message says what happened."""


class TemplateError(ValueError):
    """A renderer command that cannot be used; the message names the problem."""


@dataclass(frozen=True)
class RendererCommand:
    words: tuple[str, ...]
    name: str
    output_format: str = "exr"

    @property
    def uses_mode(self) -> bool:
        return any("{mode}" in w for w in self.words)

    @property
    def uses_xml(self) -> bool:
        return any("{scene_xml}" in w for w in self.words)

    @property
    def uses_size(self) -> bool:
        """The command passes the size on ({width} or {height}), or can read it ({scene_xml}'s
        film has it)."""
        return self.uses_xml or any("{width}" in w or "{height}" in w for w in self.words)


def renderer_name(words: list[str]) -> str:
    """A default name: the stem of the program, or of its script after an interpreter."""
    picked = words[0]
    if _INTERPRETERS.fullmatch(Path(words[0]).name):
        scripts = [w for w in words[1:] if "{" not in w and not w.startswith("-")]
        picked = scripts[0] if scripts else picked
    stem = re.sub(r"[^A-Za-z0-9._-]", "_", Path(picked).stem).lstrip("._-")
    return stem[:64] or "renderer"


def parse_command(
    template: str, name: str | None = None, output_format: str = "exr"
) -> RendererCommand:
    """Checks the template: it parses, names only known placeholders and writes {out}."""
    try:
        words = shlex.split(template)
    except ValueError as e:
        raise TemplateError(f"--renderer {template!r}: {e}") from None
    if not words:
        raise TemplateError("--renderer is empty")
    for w in words:
        for field in PLACEHOLDER.findall(w):
            if field not in PLACEHOLDERS:
                raise TemplateError(
                    f"--renderer: unknown placeholder {{{field}}} in {w!r} "
                    f"(known: {', '.join('{' + p + '}' for p in PLACEHOLDERS)})"
                )
    if not any("{out}" in w for w in words):
        raise TemplateError("--renderer must write the image {out} (e.g. '... -o {out}')")
    if "{" in words[0]:
        raise TemplateError(f"--renderer: the program {words[0]!r} may not be a placeholder")
    if output_format not in OUTPUT_FORMATS:
        raise TemplateError(
            f"--output-format {output_format!r}: expected one of {', '.join(OUTPUT_FORMATS)}"
        )
    chosen = name if name is not None else renderer_name(words)
    if not _NAME.fullmatch(chosen):
        raise TemplateError(
            f"--renderer-name {chosen!r}: use 1-64 letters, digits, '.', '_' or '-' "
            "(it names the baseline folder)"
        )
    return RendererCommand(tuple(words), chosen, output_format)


@dataclass
class ForeignRender:
    image: Image
    seconds: float  # the renderer's wall time alone
    command: list[str]


def _write_xml(scene: Scene, folder: Path, spp: int) -> Path:

    path = folder / "scene.xml"
    export_scene(scene, ExportOptions(spp=spp)).write(path)
    return path


@dataclass(frozen=True)
class SceneRequest:
    """One scene to render: what the placeholders stand for."""

    scene: Scene
    scene_file: Path
    size: tuple[int, int]
    spp: int = 1
    mode: str = "default"
    # Where the size came from ("--size", "baseline", "scene"), for the advice on a wrongly
    # sized image.
    size_from: str = "--size"


def _values(cmd: RendererCommand, request: SceneRequest, out: Path) -> dict[str, str]:
    """What each placeholder stands for; {scene_xml} is written into `out`'s folder."""
    scene, spp, mode = request.scene, request.spp, request.mode
    width, height = request.size
    values = {
        "scene": str(Path(request.scene_file).resolve()),
        "out": str(out),
        "width": str(width),
        "height": str(height),
        "spp": str(spp),
        "mode": mode,
        "scene_xml": "",
    }
    if cmd.uses_xml:
        sized = dataclasses.replace(
            scene, camera=dataclasses.replace(scene.camera, width=width, height=height)
        )
        values["scene_xml"] = str(_write_xml(sized, out.parent, spp))
    return values


def _run_sandboxed(
    cmd: RendererCommand,
    values: dict[str, str],
    out: Path,
    size: tuple[int, int],
    timeout: float | None,
) -> tuple[float, list[str]]:
    """Runs the renderer in the sandbox (compare/render/foreign_sandboxed.py) and moves its
    image to `out`; (seconds, the command it ran)."""
    try:
        kept, seconds, argv = render_sandboxed(list(cmd.words), values, out.name, size, timeout)
    except SandboxedRenderFailed as e:
        raise RenderFailed(str(e)) from None
    shutil.move(kept, out)
    kept.parent.rmdir()
    return seconds, argv


def render(
    cmd: RendererCommand,
    request: SceneRequest,
    *,
    timeout: float | None = None,
    sandbox: bool = False,
) -> ForeignRender:
    """Runs the renderer on one scene and reads its image. Raises RenderFailed naming the
    command, the exit status or time limit, and the end of its stderr."""
    width, height = size = request.size
    with tempfile.TemporaryDirectory(prefix="rtval-render-") as tmp:
        out = Path(tmp) / f"out.{cmd.output_format}"
        values = _values(cmd, request, out)
        if sandbox:
            seconds, argv = _run_sandboxed(cmd, values, out, size, timeout)
            shown, tail = shlex.join(argv), ""
        else:
            argv = [fill(w, values) for w in cmd.words]
            shown = shlex.join(argv)
            seconds, tail = _run_plain(argv, shown, out, timeout)
        try:
            image = read_image(out)
        except ImageError as e:
            raise RenderFailed(f"unreadable image: {e}{tail}") from None
        if image.shape != (height, width):
            got = f"{image.shape[1]}x{image.shape[0]}"
            raise RenderFailed(
                f"image is {got}, expected {width}x{height} ({{width}}x{{height}}"
                f"{_size_advice(cmd, request.size_from, got)}): {shown}{tail}"
            )
        image.path = f"{cmd.name}:{request.scene.name}"
        return ForeignRender(image, seconds, argv)


_STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


def _run_plain(argv: list[str], shown: str, out: Path, timeout: float | None) -> tuple[float, str]:
    """Runs the renderer in its own process group; (seconds, the end of its stderr)."""
    start = time.perf_counter()
    # A stop signal is held until the renderer is ours to kill: raised inside Popen, it
    # would leave a renderer that no one knows running (in its own session, out of reach).
    held = signal.pthread_sigmask(signal.SIG_BLOCK, _STOP_SIGNALS)
    try:
        proc = subprocess.Popen(
            argv,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            start_new_session=True,  # its own process group: a timeout kills its children
            preexec_fn=lambda: signal.pthread_sigmask(signal.SIG_SETMASK, held),
        )
    except BaseException as e:
        signal.pthread_sigmask(signal.SIG_SETMASK, held)
        if isinstance(e, OSError):
            raise RenderFailed(f"cannot start {shown}: {e.strerror or e}") from None
        raise
    assert proc.stderr is not None
    try:  # from here on, a signal (rtval's SIGTERM is a Stopped) kills the renderer's group
        signal.pthread_sigmask(signal.SIG_SETMASK, held)  # one that came is raised here
        stderr = _Tail(proc.stderr.fileno())
        proc.stderr.close()  # the reader has its own copy of the pipe
        proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        _kill_group(proc)
        raise RenderFailed(f"timed out after {timeout:g} s: {shown}") from None
    except BaseException:  # interrupted: leave no renderer running
        _kill_group(proc)
        raise
    seconds = time.perf_counter() - start
    err = stderr.text()
    tail = f"\nrenderer stderr:\n{err}" if err else ""
    if proc.returncode != 0:
        raise RenderFailed(f"exit status {proc.returncode}: {shown}{tail}")
    if not out.is_file():
        raise RenderFailed(f"wrote no image {out.name} (expected at {{out}}): {shown}{tail}")
    return seconds, tail


class _Tail:
    """The last STDERR_KEPT characters of a pipe, read by a thread: a renderer printing
    300 MB costs no memory, and one whose detached child keeps the pipe open costs no wait."""

    def __init__(self, fd: int) -> None:
        self.fd, self.kept = os.dup(fd), bytearray()  # its own copy, closed when it ends
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.thread.start()

    def _read(self) -> None:
        try:
            while chunk := os.read(self.fd, 1 << 16):
                self.kept += chunk
                del self.kept[: max(0, len(self.kept) - 4 * STDERR_KEPT)]
        except OSError:
            pass
        finally:
            os.close(self.fd)

    def text(self) -> str:
        self.thread.join(timeout=1.0)  # the renderer has exited; its children may not have
        raw = bytes(self.kept).decode("utf-8", "replace").strip()[-STDERR_KEPT:]
        return displayable(raw, lines=True)  # no terminal escapes, no reordered lines


def _size_advice(cmd: RendererCommand, size_from: str, got: str) -> str:
    """What to do about an image of another size than asked, when the command cannot be
    told the size."""
    if cmd.uses_size or size_from == "scene":
        return ""
    if size_from == "baseline":
        return (
            f"; that is its baseline's size, and the command has no {{width}}/{{height}}: "
            f"--size {got} --update rewrites the baseline at the size it writes"
        )
    return "; the command has no {width}/{height}: leave out --size to render at the scene's size"


def _kill_group(proc: subprocess.Popen[bytes]) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()  # not the pipe: a child that left the group (setsid) may hold it open
