"""`rtval export` and `rtval reference` replace only regular files they do not read: the
hostile-input pass found both replacing a device node, a FIFO, a symlink's target, the input
scene itself, and writing through a symlink planted at their fixed temporary names."""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import pytest
from helpers import SCENES, run

RTVAL = str(Path(sys.executable).with_name("rtval"))


@pytest.fixture
def scene(tmp_path: Path) -> Path:
    p = tmp_path / "paper.json"
    shutil.copy(SCENES / "paper.json", p)
    return p


def test_export_refuses_to_overwrite_its_scene(scene: Path) -> None:
    before = scene.read_bytes()
    proc = run([RTVAL, "export", str(scene), "-o", str(scene)])
    assert proc.returncode == 64 and "names the same file as SCENE" in proc.stderr, proc.stderr
    assert scene.read_bytes() == before


@pytest.mark.parametrize("kind", ["fifo", "symlink", "folder"])
def test_export_and_reference_refuse_a_special_output(
    scene: Path, tmp_path: Path, kind: str
) -> None:
    out = tmp_path / "out.xml"
    victim = tmp_path / "victim.txt"
    victim.write_text("keep")
    if kind == "fifo":
        os.mkfifo(out)
    elif kind == "symlink":
        out.symlink_to(victim)
    else:
        out.mkdir()
    for cmd in (["export", str(scene), "-o", str(out)], ["reference", str(scene), "-o", str(out)]):
        proc = run([RTVAL, *cmd, "--spp", "1"])
        assert proc.returncode == 4 and "outputs only ever replace regular files" in proc.stderr, (
            cmd,
            proc.stderr,
        )
    assert victim.read_text() == "keep" and os.path.lexists(out)


def test_a_link_planted_at_the_old_temporary_names_is_never_written_through(tmp_path: Path) -> None:
    scene = tmp_path / "lit.json"
    shutil.copy(SCENES / "lit.json", scene)  # its floor becomes a PLY cap mesh
    victim = tmp_path / "victim.txt"
    victim.write_text("keep")
    out = tmp_path / "scene.xml"
    (tmp_path / "scene.xml.tmp").symlink_to(victim)
    (tmp_path / "lit_sphere_0_cap.ply.tmp").symlink_to(victim)
    proc = run([RTVAL, "export", str(scene), "-o", str(out)])
    assert proc.returncode == 0, proc.stderr
    assert victim.read_text() == "keep"
    assert out.read_text().startswith("<?xml") and list(tmp_path.glob("*.ply"))
