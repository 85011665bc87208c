"""`grade --handout DIR` (compare/grading/student_page.write_handouts) copies each student's
page folder and nothing else: no link inside a page folder is followed or copied, a link
planted at a handout folder's name stops it, and a student whose page is gone is skipped."""

from __future__ import annotations

from pathlib import Path

import pytest

from compare.grading.results import StudentResult
from compare.grading.student_page import write_handouts


def _student(sid: str) -> StudentResult:
    return StudentResult(sid, "k", "pass", 100.0, "classic", "", "", (), "r", 0.0, "p")


def test_only_the_pages_regular_files_travel(tmp_path: Path) -> None:
    out, secret = tmp_path / "out", tmp_path / "secret.txt"
    secret.write_text("the answers")
    page = out / "students" / "ann"
    page.mkdir(parents=True)
    (page / "index.html").write_text("<html>ann</html>")
    (page / "classic.png").write_bytes(b"png")
    (page / "answers.png").symlink_to(secret)
    made = write_handouts([_student("ann"), _student("gone")], out, tmp_path / "handout")
    assert made == [tmp_path / "handout" / "ann"]
    assert sorted(p.name for p in made[0].iterdir()) == ["classic.png", "index.html"]
    assert (made[0] / "index.html").read_text() == "<html>ann</html>"


def test_a_link_at_a_handout_folder_stops_it(tmp_path: Path) -> None:
    out, victim = tmp_path / "out", tmp_path / "victim"
    (out / "students" / "ann").mkdir(parents=True)
    (out / "students" / "ann" / "index.html").write_text("page")
    victim.mkdir()
    (tmp_path / "handout").mkdir()
    (tmp_path / "handout" / "ann").symlink_to(victim)
    with pytest.raises(OSError, match="link"):
        write_handouts([_student("ann")], out, tmp_path / "handout")
    assert not list(victim.iterdir())
