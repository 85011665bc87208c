"""compare/sandbox/trees.py: walks over what a student made are iterative and bounded, and a
tree of any depth is removed; a build or a run that leaves 2,500 nested folders, and a
submission 1,500 folders deep, are rows with a reason and leave nothing in /tmp."""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from pathlib import Path

import pytest
from sandbox_class import LIMITS, MAKEFILE, grade, gradebook, hooks, private_tmp, student

from compare.sandbox.archives import TreeLimits, copy_tree, source_digest
from compare.sandbox.bwrap import probe
from compare.sandbox.trees import TreeError, remove_tree, walk

pytestmark = pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")


# 2,500 nested folders, made from inside (a shell's cd gives up past PATH_MAX)
DEEP = """#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
static void deep(void) {
    int back = open(".", O_RDONLY);
    for (int i = 0; i < 2500; i++) { mkdir("d", 0755); if (chdir("d") != 0) _exit(9); }
    if (fchdir(back) != 0) _exit(10);
}
"""


def _deep(root: Path, depth: int, name: str = "d") -> None:
    """depth nested folders below root, made by descriptor (the path outgrows PATH_MAX)."""
    fd = os.open(root, os.O_RDONLY | os.O_DIRECTORY)
    try:
        for i in range(depth):
            os.mkdir(name, dir_fd=fd)
            if i % 700 == 0:
                os.close(os.open("f", os.O_CREAT | os.O_WRONLY, 0o644, dir_fd=fd))
            child = os.open(name, os.O_RDONLY | os.O_DIRECTORY, dir_fd=fd)
            os.close(fd)
            fd = child
    finally:
        os.close(fd)


def test_a_tree_deeper_than_path_max_is_removed(tmp_path: Path) -> None:
    top = tmp_path / "top"
    top.mkdir()
    _deep(top, 2500, "n" * 100)
    (top / "link").symlink_to(tmp_path)  # removed, never followed
    keep = tmp_path / "keep.txt"
    keep.write_text("stays")
    remove_tree(top)
    assert not top.exists() and keep.read_text() == "stays"


@pytest.fixture
def scratch(tmp_path: Path) -> Iterator[Path]:
    """tmp_path, emptied by remove_tree afterwards: pytest's own clean-up of old temporary
    folders recurses and would fail on the deep trees made here."""
    yield tmp_path
    for entry in tmp_path.iterdir():
        remove_tree(entry)


def test_walk_is_bounded_in_depth_and_entries(scratch: Path) -> None:
    tmp_path = scratch
    _deep(tmp_path, 100)
    with pytest.raises(TreeError, match="nested over 32 deep"):
        list(walk(tmp_path, 32, 10_000))
    with pytest.raises(TreeError, match="more than 10 files"):
        list(walk(tmp_path, 1000, 10))
    assert len(list(walk(tmp_path, 1000, 10_000))) == 100 + 1  # the folders and one file


def test_copy_and_digest_of_a_1500_deep_folder_say_why(scratch: Path) -> None:
    tmp_path = scratch
    src = tmp_path / "src"
    src.mkdir()
    _deep(src, 1500)
    with pytest.raises(TreeError, match="nested over 32"):
        copy_tree(src, tmp_path / "dest", TreeLimits())
    assert len(source_digest(src)) == 24  # a key, not a RecursionError


@pytest.mark.skipif(probe() is not None, reason=f"no sandbox here: {probe()}")
def test_deep_trees_from_builds_runs_and_submissions_are_rows(scratch: Path) -> None:
    tmp_path = scratch
    subs = tmp_path / "subs"
    student(subs / "good")
    build = MAKEFILE + "\tcc -o deep deep.c && ./deep\n"
    student(
        subs / "deep_build",
        makefile=build,
        **{"deep.c": f"{DEEP}\nint main(void) {{ deep(); return 0; }}\n"},
    )
    student(subs / "deep_run", hooks("deep();"), **{"deep.h": DEEP})  # then it renders
    _deep(student(subs / "deep_source"), 1500)
    with private_tmp() as tmp:
        proc = grade(subs, tmp_path / "out", tmp=tmp)
        left = os.listdir(tmp)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "RecursionError" not in proc.stderr
    book = gradebook(tmp_path / "out")
    assert book["good"]["status"] == "pass"
    assert book["deep_run"]["status"] == "pass", book["deep_run"]
    assert (
        "build failed: the build left folders nested over 32 deep" in book["deep_build"]["reasons"]
    )
    assert "refused: folders nested over 32 deep" in book["deep_source"]["reasons"]
    assert not (tmp_path / "out" / "programs" / "deep_build" / "build" / "tree").exists()
    assert left == [], left  # every workspace removed
    assert LIMITS  # the class ran under the small limits
