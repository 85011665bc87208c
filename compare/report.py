"""`rtval report`: the paper scene through the renderers into reports/<scene>/.

Every number in the report comes with the command that regenerates it.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
import platform
import shlex
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Callable

from jinja2 import Environment, PackageLoader, select_autoescape

from compare.images import read_image
from compare.tools import run_rtdemo
from mitsuba_ref.scene import load_scene


@dataclass
class RenderEntry:
    key: str
    label: str
    command: list[str]
    exr: str
    png: str
    seconds: float
    header: dict[str, str]

    @property
    def command_text(self) -> str:
        return shlex.join(self.command)


# The demo renders of this report: (key, label, extra rtdemo arguments).
DEMO_RENDERS = [
    ("demo-paper-cpu", "demo, paper mode (CPU)", ["--mode", "paper"]),
    ("demo-classic-cpu", "demo, classic mode (CPU)", ["--mode", "classic"]),
    ("demo-physical-cpu", "demo, physical mode (CPU)", ["--mode", "physical"]),
]


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(path)


def build_report(
    scene_path: str | Path,
    reports_dir: str | Path = "reports",
    *,
    size: tuple[int, int] | None = None,
    progress: Callable[[str], None] = print,
) -> Path:
    """Renders the scene with every renderer and writes reports/<scene>/index.html."""
    scene = load_scene(scene_path)
    out = Path(reports_dir) / scene.name
    out.mkdir(parents=True, exist_ok=True)
    size_args = ["--width", str(size[0]), "--height", str(size[1])] if size else []

    entries: list[RenderEntry] = []
    for i, (key, label, extra) in enumerate(DEMO_RENDERS, 1):
        exr, png = out / f"{key}.exr", out / f"{key}.png"
        cmd = ["rtdemo", "render", str(scene_path), "-o", str(exr), "--png", str(png), "-q",
               *extra, *size_args]
        start = time.perf_counter()
        run_rtdemo(cmd[1:])
        wall = time.perf_counter() - start
        header = read_image(exr).header
        seconds = float(header.get("rtval.render_seconds", wall))
        progress(f"[{i}/{len(DEMO_RENDERS)}] {label}: {seconds:.3f} s render, {wall:.2f} s wall")
        entries.append(RenderEntry(key, label, cmd, exr.name, png.name, seconds, header))

    data = {
        "scene": scene.name,
        "scene_file": str(scene_path),
        "scene_sha256": _sha256(Path(scene_path)),
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "machine": f"{platform.node()} {platform.machine()} {platform.system()} {platform.release()}",
        "python": sys.version.split()[0],
        "command": shlex.join(["rtval", "report", str(scene_path)]),
        "renders": [asdict(e) | {"command_text": e.command_text,
                                 "exr_sha256": _sha256(out / e.exr)} for e in entries],
    }
    _write_atomic(out / "report.json", json.dumps(data, indent=2) + "\n")
    env = Environment(loader=PackageLoader("compare", "templates"),
                      autoescape=select_autoescape(["html", "j2"]))
    html = env.get_template("report.html.j2").render(report=data)
    _write_atomic(out / "index.html", html)
    return out / "index.html"
