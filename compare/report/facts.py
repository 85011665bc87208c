"""The facts a report records about where it was made: the versions of what rendered and
judged it, and the machine."""

from __future__ import annotations

import contextlib
import importlib.metadata
import os
import platform
import subprocess
from pathlib import Path

from compare.errors import ToolError
from compare.render.runner import rtdemo_path

DISTRIBUTIONS = (
    "rtval",
    "mitsuba",
    "drjit",
    "numpy",
    "scikit-image",
    "flip-evaluator",
    "OpenEXR",
    "matplotlib",
    "jinja2",
)


def versions() -> dict[str, str]:
    v = {}
    for dist in DISTRIBUTIONS:
        try:
            v[dist] = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            v[dist] = "not installed"
    try:
        v["rtdemo"] = subprocess.run(
            [rtdemo_path(), "--version"], capture_output=True, text=True, check=False
        ).stdout.strip()
    except ToolError:
        v["rtdemo"] = "not found"
    v["python"] = platform.python_version()
    return v


def machine() -> str:
    cpu = ""
    with contextlib.suppress(OSError):
        cpu = next(
            (
                line.split(":", 1)[1].strip()
                for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")
            ),
            "",
        )
    return f"{cpu or platform.processor()} x {os.cpu_count()} cores, {platform.system()} {platform.release()}"
