"""compare.grading.lms.stage_submission: Gradescope's submission folder is a student's tree,
copied as the student made it (links as links, for grading to refuse) and within the bounds
of a submitted folder, however deep it is."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from compare.grading.lms import stage_submission, submission_identity
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


FIXTURE = Path(__file__).resolve().parent / "gradescope" / "submission_metadata.json"


def test_the_student_is_named_by_gradescopes_metadata(tmp_path: Path) -> None:
    # The fixture has the shape of Gradescope's "Submission Metadata" page: users[] of
    # {email, id, name}, two of them (a group submission).
    shutil.copyfile(FIXTURE, tmp_path / "submission_metadata.json")
    who = submission_identity(tmp_path)
    assert who.student == "ada@example.edu+alan@example.edu"
    assert who.names == "Ada Student, Alan Student" and who.source.endswith("users[].email")


def test_without_emails_the_gradescope_user_id_names_the_student(tmp_path: Path) -> None:
    meta = json.loads(FIXTURE.read_text())
    meta["users"] = [{"id": 1815, "name": "Ada Student"}]
    (tmp_path / "submission_metadata.json").write_text(json.dumps(meta))
    who = submission_identity(tmp_path)
    assert (who.student, who.source.rsplit(": ", 1)[1]) == ("1815", "users[].id")


@pytest.mark.parametrize(
    ("content", "why"),
    [(None, "no "), ("{not json", "unreadable"), ('{"users": []}', "no users[]")],
)
def test_no_usable_metadata_is_the_id_submission_said_as_such(
    tmp_path: Path, content: str | None, why: str
) -> None:
    if content is not None:
        (tmp_path / "submission_metadata.json").write_text(content)
    who = submission_identity(tmp_path)
    assert who.student == "submission" and why in who.source
