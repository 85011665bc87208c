"""`rtval check --renderer ... --sandbox`: the renderer runs in the grading sandbox
(compare/sandbox/bwrap.py). A correct renderer gets the verdict it gets outside; one that tries to
read a file of the caller's, or to write outside its folders, finds nothing and leaves
nothing."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import SCENES, run

from compare.sandbox.bwrap import probe

RTVAL = str(Path(sys.executable).with_name("rtval"))
TRACER = Path(__file__).parent / "foreign" / "classic_tracer.cpp"
SNOOP = """
import os, sys
secret, marker = SECRET, MARKER  # known to the script, not named in its command
tracer, out, w, h = sys.argv[1:]
for path in (secret, os.path.expanduser("~/.bashrc")):
    try:
        open(path).read()
        sys.exit(7)  # it could read the caller's file: the check must not pass
    except OSError:
        pass
for where in (marker, "/tmp/rtval-sandbox-escape"):
    try:
        open(where, "w").write("escaped")
    except OSError:
        pass
os.execv(tracer, [tracer, out, w, h])
"""


@pytest.fixture(scope="module")
def tracer(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if probe() is not None:
        pytest.skip(f"no sandbox here: {probe()}")
    exe = tmp_path_factory.mktemp("tracer") / "classic_tracer"
    subprocess.run(["g++", "-O2", "-o", str(exe), str(TRACER)], check=True)
    return exe


def _check(renderer: str, *extra: str) -> subprocess.CompletedProcess[str]:
    return run(
        [RTVAL, "check", "--renderer", renderer, "--output-format", "ppm", "--against", "classic",
         "--scenes", str(SCENES / "classic.json"), "--size", "160x120", *extra]
    )  # fmt: skip


def test_a_correct_renderer_passes_sandboxed_as_it_does_outside(tracer: Path) -> None:
    cmd = f"{tracer} {{out}} {{width}} {{height}}"
    outside, inside = _check(cmd), _check(cmd, "--sandbox")
    assert outside.returncode == inside.returncode == 0, inside.stdout + inside.stderr
    assert "1 passed, 0 failed" in inside.stdout and "PASS  against classic" in inside.stderr


def test_the_renderer_reads_and_writes_nothing_of_the_callers(tracer: Path, tmp_path: Path) -> None:
    secret, marker = tmp_path / "secret.txt", tmp_path / "escaped.txt"
    secret.write_text("the answer")
    script = tmp_path / "snoop.py"
    script.write_text(f"SECRET, MARKER = {str(secret)!r}, {str(marker)!r}\n" + SNOOP)
    cmd = f"python3 {script} {tracer} {{out}} {{width}} {{height}}"
    proc = _check(cmd, "--sandbox")
    assert proc.returncode == 0, proc.stdout + proc.stderr  # 7 had it read the secret
    assert not marker.exists() and not Path("/tmp/rtval-sandbox-escape").exists()
    unsandboxed = _check(cmd)  # the same renderer outside reads the secret
    assert unsandboxed.returncode == 2 and "exit status 7" in unsandboxed.stdout
    marker.unlink(missing_ok=True)
    shutil.rmtree("/tmp/rtval-sandbox-escape", ignore_errors=True)


def test_sandbox_needs_a_renderer() -> None:
    proc = run([RTVAL, "check", "--sandbox"])
    assert proc.returncode == 64 and "--sandbox need --renderer" in proc.stderr
