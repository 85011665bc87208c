"""Building and running the corpus of foreign programs (tests/corpus/*), and judging what
they render with `rtval compare --against MODEL` and `rtval diagnose`.

A Variant is one program built one way (compiler, flags, defines, environment) and run on
one scene at one size. Builds go into a folder of the caller's (a per-session temporary
folder in the tests) and are shared by the variants that need the same build. Every process
runs in its own process group under a time limit, and the whole group is killed when it
runs over, so a broken build or a program that never ends cannot hang a test run.

`differences` lists, pixel by pixel, what stands between an image and exact agreement with
its model (the rule of docs/metrics.md, "Exact match", re-done here independently, so that
a report can say where the pixels are and what their codes are).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

CORPUS = Path(__file__).resolve().parent
ROOT = CORPUS.parent.parent
SCENES = ROOT / "scenes"
RTVAL = str(Path(sys.executable).with_name("rtval"))

BUILD_TIMEOUT = 240.0  # s: go's first build on an empty cache compiles its runtime (~25 s)
RUN_TIMEOUT = 120.0  # s: the slowest variant (-O0 at 640x480) takes a few seconds
JUDGE_TIMEOUT = 300.0  # s: compare renders the model five times on a cold render cache

TOOLS = {
    "g++": "C++ (GNU)",
    "clang++": "C++ (LLVM)",
    "gcc": "C (GNU)",
    "clang": "C (LLVM)",
    "rustc": "Rust",
    "go": "Go",
    "node": "JavaScript (Node)",
}
_CXX_STD = "-std=gnu++17"  # g++ 12's default dialect; clang 14's is gnu++14
_C_STD = "-std=c99"


class CorpusError(RuntimeError):
    """A build, a run or a judgement failed; the message says which command and why."""


@dataclass(frozen=True)
class Build:
    """A program of the corpus and how it is built."""

    source: str  # a file in tests/corpus
    tool: str  # a key of TOOLS
    flags: tuple[str, ...] = ()
    defines: tuple[str, ...] = ()  # NAME or NAME=VALUE, given as -D
    env: tuple[tuple[str, str], ...] = ()  # extra environment of the build (GOAMD64=v3)
    needs_fma: bool = False  # the flags make code that only runs on a CPU with FMA

    def command(self, exe: Path | str = "PROG") -> list[str]:
        src = str(CORPUS / self.source)
        defs = [f"-D{d}" for d in self.defines]
        if self.tool in ("g++", "clang++"):
            return [self.tool, _CXX_STD, *self.flags, *defs, "-o", str(exe), src, "-lm"]
        if self.tool in ("gcc", "clang"):
            return [self.tool, _C_STD, *self.flags, *defs, "-o", str(exe), src, "-lm"]
        if self.tool == "rustc":
            return ["rustc", "--edition", "2021", *self.flags, "-o", str(exe), src]
        if self.tool == "go":
            return ["go", "build", *self.flags, "-o", str(exe), src]
        if self.tool == "node":
            return []
        raise ValueError(f"unknown tool {self.tool!r}")

    def describe(self) -> str:
        """The build as a person would type it, e.g. `g++ -std=gnu++17 -O2 x.cpp`."""
        if self.tool == "node":
            return f"node {self.source}"
        words = [w for w in self.command() if w not in ("-o", "PROG", "-lm")]
        words[-1] = self.source
        env = " ".join(f"{k}={v}" for k, v in self.env)
        return f"{env} {' '.join(words)}".strip()

    def key(self) -> str:
        text = json.dumps(
            [self.source, self.tool, self.flags, self.defines, self.env],
            separators=(",", ":"),
        )
        body = (CORPUS / self.source).read_bytes()
        return hashlib.sha256(text.encode() + body).hexdigest()[:16]


@dataclass(frozen=True)
class Variant:
    """One build run on one scene at one size, judged against one model."""

    name: str
    build: Build
    scene: str = "classic"  # scenes/NAME.json
    against: str = "classic"
    size: tuple[int, int] = (320, 240)
    argv: tuple[str, ...] = ("{w}", "{h}", "{out}")  # the program's arguments
    mistake: str | None = None  # what the variant does wrong; None: a correct program
    note: str = ""
    # What `rtval diagnose` may say of a mistake: `causes`, the cause names (the diagnosis
    # JSON's causes[*].name) that are true of it, one of which it should name and none
    # outside which it may name; `steps`, the steps of the algorithm (docs/diagnosis.md's
    # vocabulary) where the error lives, where it names no cause.
    causes: frozenset[str] = frozenset()
    steps: frozenset[str] = frozenset()

    @property
    def scene_file(self) -> Path:
        return SCENES / f"{self.scene}.json"

    def arguments(self, out: Path) -> list[str]:
        w, h = self.size
        return [a.format(w=w, h=h, out=out) for a in self.argv]


@dataclass
class Outcome:
    """What a variant rendered and what the judge said about it."""

    variant: Variant
    image: Path
    compare: dict[str, Any]
    compare_rc: int
    diagnosis: dict[str, Any] | None = None
    seconds: dict[str, float] = field(default_factory=dict)

    @property
    def status(self) -> str:
        return str(self.compare["status"])

    @property
    def score(self) -> float:
        return float(self.compare["score"]["score"])

    @property
    def failing_effects(self) -> list[str]:
        effects = self.compare["score"]["effects"]
        return sorted(k for k, e in effects.items() if e["status"] != "pass")

    def differing(self) -> dict[str, int]:
        """Per effect, the pixels that differ from the model (the judge's count)."""
        per = self.compare["exact"]["per_effect"]
        return {k: int(e["differing"]) for k, e in per.items()}

    def unstable(self) -> dict[str, int]:
        """Per effect, the pixels matched only within the model's own spread."""
        per = self.compare["exact"]["per_effect"]
        return {k: int(e.get("unstable", e.get("edge_ambiguous", 0))) for k, e in per.items()}


# --- running processes ---------------------------------------------------------------------


def run_bounded(
    cmd: list[str],
    timeout: float,
    *,
    env: dict[str, str] | None = None,
    cwd: Path | None = None,
) -> subprocess.CompletedProcess[str]:
    """Runs `cmd` in its own process group; past `timeout` seconds the whole group is killed
    (a compiler's children too) and CorpusError says so."""
    with subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        stdin=subprocess.DEVNULL,
        text=True,
        env=env,
        cwd=cwd,
        start_new_session=True,
    ) as proc:
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
            raise CorpusError(
                f"{' '.join(cmd)}: still running after {timeout:g} s, killed"
            ) from None
        return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def cpu_has_fma() -> bool:
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return False
    return any(
        line.startswith("flags") and "fma" in line.split(":", 1)[1].split()
        for line in text.splitlines()
    )


def missing(build: Build) -> str | None:
    """Why this build cannot be made on this machine (a toolchain that is not installed, a
    CPU without FMA), or None."""
    if shutil.which(build.tool) is None:
        return f"{build.tool} ({TOOLS[build.tool]}) is not installed"
    if build.needs_fma and not cpu_has_fma():
        return "this CPU has no FMA (no 'fma' flag in /proc/cpuinfo)"
    return None


def _tool_env(build: Build, folder: Path) -> dict[str, str]:
    env = dict(os.environ)
    if build.tool == "go":
        # Offline and with the installed toolchain only; outside any module.
        env.update(GOTOOLCHAIN="local", GOPROXY="off", GOFLAGS="", GO111MODULE="on")
        if not (env.get("GOCACHE") or env.get("XDG_CACHE_HOME") or env.get("HOME")):
            env["GOCACHE"] = str(folder / "go-cache")
        if not (env.get("GOPATH") or env.get("HOME")):
            env["GOPATH"] = str(folder / "go-path")
    env.update(dict(build.env))
    return env


class Builder:
    """Builds programs into `folder`, each build once (thread-safe: variants sharing a build
    wait for the first one to finish it)."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self._lock = threading.Lock()
        self._locks: dict[str, threading.Lock] = {}
        self._done: dict[str, list[str]] = {}
        self.seconds: dict[str, float] = {}

    def program(self, build: Build) -> list[str]:
        """The command that runs the built program (its arguments follow)."""
        if build.tool == "node":
            return ["node", str(CORPUS / build.source)]
        key = build.key()
        with self._lock:
            lock = self._locks.setdefault(key, threading.Lock())
        with lock:
            if key in self._done:
                return self._done[key]
            out = self.folder / "bin" / f"{Path(build.source).stem}-{key}"
            out.parent.mkdir(parents=True, exist_ok=True)
            work = self.folder / "build" / key
            work.mkdir(parents=True, exist_ok=True)
            start = time.monotonic()
            proc = run_bounded(
                build.command(out), BUILD_TIMEOUT, env=_tool_env(build, self.folder), cwd=work
            )
            self.seconds[key] = time.monotonic() - start
            if proc.returncode != 0 or not out.is_file():
                raise CorpusError(
                    f"build failed ({proc.returncode}): {build.describe()}\n{proc.stderr[-3000:]}"
                )
            self._done[key] = [str(out)]
            return self._done[key]


# --- rendering and judging -----------------------------------------------------------------


def render(builder: Builder, variant: Variant, out: Path) -> Path:
    cmd = [*builder.program(variant.build), *variant.arguments(out)]
    proc = run_bounded(cmd, RUN_TIMEOUT, cwd=out.parent)
    if proc.returncode != 0 or not out.is_file():
        raise CorpusError(
            f"{variant.name}: {' '.join(cmd)} exited {proc.returncode}\n{proc.stderr}"
        )
    return out


def compare(image: Path, variant: Variant, json_out: Path) -> tuple[dict[str, Any], int]:
    """`rtval compare IMAGE --against MODEL --scene S --json F`: the JSON and the exit code."""
    cmd = [RTVAL, "compare", str(image), "--against", variant.against]
    cmd += ["--scene", str(variant.scene_file), "--json", str(json_out), "-q"]
    proc = run_bounded(cmd, JUDGE_TIMEOUT)
    if proc.returncode not in (0, 1, 2) or not json_out.is_file():
        raise CorpusError(f"{' '.join(cmd)} exited {proc.returncode}\n{proc.stderr[-3000:]}")
    return json.loads(json_out.read_text()), proc.returncode


def diagnose(image: Path, variant: Variant, json_out: Path) -> dict[str, Any]:
    """`rtval diagnose IMAGE --scene S --json F`: the diagnosis as JSON."""
    cmd = [RTVAL, "diagnose", str(image), "--scene", str(variant.scene_file)]
    cmd += ["--json", str(json_out)]
    proc = run_bounded(cmd, JUDGE_TIMEOUT)
    if proc.returncode != 0 or not json_out.is_file():
        raise CorpusError(f"{' '.join(cmd)} exited {proc.returncode}\n{proc.stderr[-3000:]}")
    data: dict[str, Any] = json.loads(json_out.read_text())
    data["text"] = proc.stdout
    return data


def run_variant(
    builder: Builder, variant: Variant, folder: Path, *, with_diagnosis: bool = False
) -> Outcome:
    """Builds, renders, compares (and diagnoses, when asked) one variant in `folder`."""
    folder.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    builder.program(variant.build)
    t1 = time.monotonic()
    image = render(builder, variant, folder / f"{variant.name}.ppm")
    t2 = time.monotonic()
    data, rc = compare(image, variant, folder / f"{variant.name}.compare.json")
    t3 = time.monotonic()
    outcome = Outcome(variant, image, data, rc)
    if with_diagnosis:
        outcome.diagnosis = diagnose(image, variant, folder / f"{variant.name}.diagnose.json")
    t4 = time.monotonic()
    outcome.seconds = {"build": t1 - t0, "render": t2 - t1, "compare": t3 - t2}
    if with_diagnosis:
        outcome.seconds["diagnose"] = t4 - t3
    return outcome


# --- where an image departs from its model -------------------------------------------------


@dataclass(frozen=True)
class Pixel:
    """A pixel whose codes are not plainly the model's (neither the truncated nor the rounded
    code of the model's value at the pixel centre). `kind` is what the judge makes of it:
    "differs" (counted against the image), "unstable" (matched within the model's own spread,
    the moves of the renders with the camera turned by a sub-pixel amount) or "slack"
    (matched within the 2^-16 value slack of the pixel-centre render)."""

    x: int
    y: int
    kind: str
    effects: tuple[str, ...]
    test: tuple[int, ...]
    model: tuple[float, ...]  # 255 x the model's value at the pixel centre
    low: tuple[float, ...]  # 255 x the lowest value of any render of the model (turned too)
    high: tuple[float, ...]

    def line(self) -> str:
        def fmt(v: tuple[float, ...]) -> str:
            return ", ".join(f"{c:.2f}" for c in v)

        return (
            f"({self.x}, {self.y}) {'/'.join(self.effects) or '-'} {self.kind}: "
            f"test {self.test}, model 255x ({fmt(self.model)}), "
            f"renders {fmt(self.low)} ... {fmt(self.high)}"
        )


def read_ppm_codes(path: Path) -> np.ndarray:
    """The 8-bit codes of a binary PPM (P6, maxval 255) as an H x W x 3 array."""
    data = path.read_bytes()
    fields: list[bytes] = []
    i = 0
    while len(fields) < 4:
        while data[i : i + 1].isspace():
            i += 1
        if data[i : i + 1] == b"#":
            i = data.index(b"\n", i)
            continue
        j = i
        while not data[j : j + 1].isspace():
            j += 1
        fields.append(data[i:j])
        i = j
    if fields[0] != b"P6" or fields[3] != b"255":
        raise ValueError(f"{path}: not a binary 8-bit PPM")
    w, h = int(fields[1]), int(fields[2])
    pixels = np.frombuffer(data[i + 1 : i + 1 + w * h * 3], np.uint8)
    return pixels.reshape(h, w, 3).astype(np.int64)


def differences(outcome: Outcome, *, limit: int = 200) -> list[Pixel]:
    """The pixels of an 8-bit PPM outcome that are not plainly its model's (see Pixel), read
    against the renders of the model that `rtval compare` used (from the render cache) and
    classified by the judge's own exact_match."""
    from compare.judge.exact_match import exact_match
    from compare.judge.images import read_image
    from compare.judge.target_model import parse_model
    from compare.render.cache import RenderCache
    from compare.render.models import render_offsets, scene_masks

    v = outcome.variant
    codes = read_ppm_codes(outcome.image)
    cache = RenderCache()
    paths = [Path(outcome.compare["reference"])]
    paths += render_offsets(parse_model(v.against), v.scene_file, v.size, cache)
    renders = [read_image(p).rgb for p in paths]
    masks = scene_masks(v.scene_file, v.size, cache)
    judged = exact_match(renders, read_image(outcome.image).rgb, "linear", model=v.against)
    unstable = getattr(judged, "unstable", None)
    if unstable is None:  # the rule before the model's spread
        unstable = judged.ambiguous  # type: ignore[attr-defined]
    centre = renders[0].astype(np.float64)
    c = np.clip(np.nan_to_num(centre, nan=0.0), 0, 1)
    plain = ((codes == np.floor(255 * c)) | (codes == np.floor(255 * c + 0.5))).all(axis=-1)
    stack = np.stack([r.astype(np.float64) for r in renders])
    low, high = np.nanmin(stack, axis=0), np.nanmax(stack, axis=0)
    out = []
    for y, x in zip(*np.nonzero(~plain), strict=True):
        kind = "differs" if not judged.matches[y, x] else "unstable" if unstable[y, x] else "slack"
        out.append(
            Pixel(
                int(x),
                int(y),
                kind,
                tuple(k for k, m in masks.items() if m[y, x]),
                tuple(int(q) for q in codes[y, x]),
                tuple(float(255 * q) for q in centre[y, x]),
                tuple(float(255 * q) for q in low[y, x]),
                tuple(float(255 * q) for q in high[y, x]),
            )
        )
    order = {"differs": 0, "unstable": 1, "slack": 2}
    out.sort(key=lambda p: (order[p.kind], p.y, p.x))
    return out[:limit]
