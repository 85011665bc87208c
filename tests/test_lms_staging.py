"""compare.grading.lms.stage_submission: Gradescope's submission folder is a student's tree,
copied as the student made it (links as links, for grading to refuse) and within the bounds
of a submitted folder, however deep it is."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from compare.grading.lms import stage_submission
from compare.sandbox.trees import TreeError, remove_tree


def test_the_submission_is_copied_with_its_links_as_links(tmp_path: Path) -> None:
    sub = tmp_path / "root" / "submission"
    (sub / "carol").mkdir(parents=True)
    (sub / "carol" / "classic.ppm").write_bytes(b"P6\n1 1\n255\n\0\0\0")
    (sub / "bob.ppm").symlink_to("/etc/passwd")
    os.mkfifo(sub / "pipe.ppm")
    staged = stage_submission(tmp_path / "root", tmp_path / "out") / "submission"
    assert (staged / "carol" / "classic.ppm").read_bytes() == b"P6\n1 1\n255\n\0\0\0"
    assert os.readlink(staged / "bob.ppm") == "/etc/passwd"
    assert not (staged / "pipe.ppm").exists()  # a FIFO is never opened, nor copied


def test_a_deep_submission_is_refused_not_a_recursion_error(tmp_path: Path) -> None:
    deep = tmp_path / "root" / "submission"
    deep.mkdir(parents=True)
    fd = os.open(deep, os.O_RDONLY)
    try:
        for _ in range(2500):  # by descriptor: the path would pass PATH_MAX
            os.mkdir("d", dir_fd=fd)
            inner = os.open("d", os.O_RDONLY, dir_fd=fd)
            os.close(fd)
            fd = inner
    finally:
        os.close(fd)
    try:
        with pytest.raises(TreeError, match="nested over"):
            stage_submission(tmp_path / "root", tmp_path / "out")
    finally:  # pytest's own clean-up recurses
        remove_tree(tmp_path / "root")
        remove_tree(tmp_path / "out")
