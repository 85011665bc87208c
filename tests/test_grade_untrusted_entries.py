"""`rtval grade` on a generated hostile class (tests/hostile_class.py): FIFO, socket,
symlinks (to the reference, /etc, /dev/zero, dangling), a 255-byte and a non-UTF-8 name,
formula and markup names, one id twice, a hidden file, the --out folder inside the
submissions, a truncated result. Nothing aborts the class; each entry is a row with its
reason (or a printed notice); nothing is followed outside the folder."""

from __future__ import annotations

import csv
import json
import os
import shutil
import sys
from pathlib import Path

import pytest
from helpers import SCENES, run
from hostile_class import HTML_NAME, LONG_STEM, make_hostile_class

from compare.student_ids import student_slug

pytestmark = pytest.mark.slow
RTVAL = str(Path(sys.executable).with_name("rtval"))
SCENE = SCENES / "classic.json"
SIZE = "32x24"


def _grade(subs: Path, out: Path) -> tuple[int, str]:
    proc = run(
        [RTVAL, "grade", str(subs), "--scene", str(SCENE), "--out", str(out), "--size", SIZE]
    )
    return proc.returncode, proc.stderr


@pytest.fixture(scope="module")
def hostile(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, dict, str]:  # type: ignore[type-arg]
    root = tmp_path_factory.mktemp("hostile")
    subs = root / "subs"
    subs.mkdir()
    out = subs / "grades"  # the --out folder inside the submissions folder
    rc, err = _grade(subs, out)  # renders the model (classic, the default) the class is made of
    assert rc == 0, err
    reference = root / "reference.exr"
    shutil.copyfile(out / "references" / "classic-classic.exr", reference)
    expected = make_hostile_class(reference, subs)
    rc, err = _grade(subs, out)
    assert rc == 0, err
    return subs, out, expected, err


def _rows(out: Path) -> dict[str, dict[str, str]]:
    with (out / "gradebook.csv").open(newline="", encoding="utf-8") as f:
        return {row["student"]: row for row in csv.DictReader(f)}


def _csv_id(sid: str) -> str:
    from compare.grading.csv_safe import neutralise

    return neutralise(sid)


def test_every_hostile_entry_is_one_row_with_its_reason(hostile) -> None:  # type: ignore[no-untyped-def]
    _, out, expected, _ = hostile
    rows = _rows(out)
    assert set(rows) == {_csv_id(s) for s in expected}  # one id, one row; nothing else
    for sid, want in expected.items():
        row = rows[_csv_id(sid)]
        if want.reason is None:
            assert row["reasons"] == "" or "unreadable" not in row["reasons"], (sid, row)
        else:
            assert want.reason in row["reasons"], (sid, row["reasons"])
        if want.status:
            assert row["status"] == want.status, (sid, row)
        if want.csv_cell:
            assert row["student"] == want.csv_cell


def test_links_are_never_followed(hostile) -> None:  # type: ignore[no-untyped-def]
    """The link to the reference would score 100 if followed; /etc would be searched."""
    _, out, _, _ = hostile
    book = json.loads((out / "gradebook.json").read_text())
    by_id = {s["student"]: s for s in book["students"]}
    for sid in ("linkref", "etcdir", "zero", "dangling"):
        assert by_id[sid]["score"] == 0.0 and by_id[sid]["status"] == "fail"


def test_hidden_and_output_folder_are_skipped_with_a_notice(hostile) -> None:  # type: ignore[no-untyped-def]
    _, out, _, stderr = hostile
    rows = _rows(out)
    assert ".hidden" not in rows and "grades" not in rows
    assert "skipping hidden entry .hidden.exr" in stderr
    assert "skipping grades/: it is the output folder" in stderr


def test_ids_on_disk_are_safe_slugs_and_pages_escape_the_id(hostile) -> None:  # type: ignore[no-untyped-def]
    _, out, _, _ = hostile
    for sid in (LONG_STEM, HTML_NAME, "=1+2", "caf\\xe9"):
        slug = student_slug(sid)
        assert len(slug) <= 80 and "/" not in slug and not slug.startswith(".")
        assert (out / "results" / f"{slug}.json").is_file()
        page = (out / "students" / slug / "index.html").read_text(encoding="utf-8")
        if sid == HTML_NAME:
            assert HTML_NAME not in page and "&lt;img src=x onerror=alert(1)&gt;" in page
    assert len({student_slug(s) for s in ("alice", "Alice", "ALICE", "a/b", "a_b")}) == 5


def test_truncated_result_is_reported_by_explain_and_regraded(hostile) -> None:  # type: ignore[no-untyped-def]
    subs, out, _, _ = hostile
    result = out / "results" / "good.json"
    result.write_text(result.read_text()[:40])  # a run killed mid-write
    proc = run([RTVAL, "grade", "--explain", "good", "--out", str(out)])
    assert proc.returncode == 4
    assert "good.json" in proc.stderr and "truncated or corrupt" in proc.stderr
    rc, err = _grade(subs, out)
    assert rc == 0, err
    assert json.loads(result.read_text())["status"] == "pass"
    proc = run([RTVAL, "grade", "--explain", "good", "--out", str(out)])
    assert proc.returncode == 0 and "good: PASS" in proc.stdout


def test_fifo_does_not_block_the_listing(tmp_path: Path) -> None:
    """collect() never opens an entry: a FIFO with no writer would block forever."""
    from compare.grading.grade import collect

    os.mkfifo(tmp_path / "f.ppm")
    (rows,) = collect(tmp_path, ["classic"])
    assert rows[0] == "f" and rows[2] is not None and "FIFO" in rows[2]


def test_an_id_named_after_a_classmates_slug_gets_its_own() -> None:
    """The hostile-input pass: 'Victim Name.ppm' and a file named with that name's slug and
    hash shared one results file, so --explain showed the classmate's PASS."""
    victim = student_slug("Victim Name")
    assert student_slug(victim) == victim.replace(".", "_") + "." + student_slug(victim)[-10:]
    assert student_slug(victim) != victim
    plain = [student_slug(s) for s in ("victim_name", "victim_name-1a2b3c4d5e")]
    assert all("." not in s for s in plain) and "." in victim
