"""What a teacher gets beside the gradebook: the class page OUT/index.html (its table sorted
by mouse and keyboard in Chromium, its links, escaped names, the histogram and the common
causes), the summary on stdout, the LMS exports (OUT/scores.csv, Gradescope's results.json
per student and `grade --gradescope` in the autograder's layout), the student pages (the
model beside the image with a flip control, the difference's scale, the points, each reason
once, a glossary, `--handout`), and 8-bit files judged in the encoding they were written in
(`--test-encoding`). A class of six at 160x120 against
classic, made by rtdemo."""

from __future__ import annotations

import csv
import html
import json
import os
import re
import shutil
import statistics
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import ROOT, SCENES, chromium_browser, render_demo, run
from PIL import Image as PILImage
from playwright.sync_api import expect

pytestmark = pytest.mark.slow
RTVAL = str(Path(sys.executable).with_name("rtval"))
ARGS = ["--scene", "classic", "--size", "160x120", "--against", "classic"]
HOSTILE = "<img src=x onerror=alert(1)>"  # a file name a student may choose
FORMULA = "=HYPERLINK(1)"
ARTIFACTS = ROOT / "build" / "test-artifacts"


@pytest.fixture(scope="module")
def subs(tmp_path_factory: pytest.TempPathFactory, rtdemo: str) -> Path:
    folder = tmp_path_factory.mktemp("class") / "subs"
    folder.mkdir()
    scene, size = SCENES / "classic.json", (160, 120)
    render_demo(rtdemo, scene, folder / "alice.ppm", "--mode", "classic", "-q", size=size)
    render_demo(rtdemo, scene, folder / "bob.png", "--mode", "classic", "-q", size=size)
    render_demo(rtdemo, scene, folder / "eve.ppm", "--mode", "paper", "-q", size=size)
    # The PPM saved as a PNG with the same bytes: linear codes in a PNG.
    PILImage.open(folder / "alice.ppm").save(folder / "carol.png")
    PILImage.open(folder / "eve.ppm").save(folder / "frank.png")  # paper mode, linear codes
    shutil.copyfile(folder / "alice.ppm", folder / f"{HOSTILE}.ppm")
    shutil.copyfile(folder / "eve.ppm", folder / f"{FORMULA}.ppm")
    (folder / "dave.png").write_bytes(b"not a picture")
    return folder


def _grade(subs: Path, out: Path, *options: str) -> str:
    proc = run([RTVAL, "grade", str(subs), *ARGS, "--out", str(out), *options])
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


@pytest.fixture(scope="module")
def graded(subs: Path) -> tuple[Path, str]:
    out = subs.parent / "grades"
    return out, _grade(subs, out, "--jobs", "2", "--handout", str(subs.parent / "handout"))


def _book(out: Path) -> dict[str, dict[str, str]]:
    with (out / "gradebook.csv").open() as f:
        return {row["student"]: row for row in csv.DictReader(f)}


def test_the_summary_on_stdout_is_the_gradebooks(graded: tuple[Path, str]) -> None:
    out, stdout = graded
    book = _book(out)
    scores = [float(r["score"]) for r in book.values()]
    passed = sum(r["status"] == "pass" for r in book.values())
    assert (len(book), passed) == (8, 4)
    assert (
        f"8 students: 4 passed, 4 failed; mean score {statistics.fmean(scores):.1f}, "
        f"median {statistics.median(scores):.1f}"
    ) in stdout
    # eve, frank and the formula-named student hand in paper mode: one cause, three students.
    assert "  3 students: looks like paper" in stdout
    assert "  1 student: unreadable image" in stdout
    # carol's passing PNG and frank's failing one both hold linear codes.
    note = "read as linear: the PNG holds the values a PPM writer stores"
    assert f"  note, 2 students: {note}" in stdout


def test_class_page_shows_every_student_escaped(graded: tuple[Path, str]) -> None:
    out, _ = graded
    page = (out / "index.html").read_text()
    assert HOSTILE not in page and html.escape(HOSTILE, quote=False) in page
    rows = re.findall(r"<tr><td class=\"text\">(.*?)</td>", page)
    ids = {k.removeprefix("'") for k in _book(out)}  # the CSV's inert formula
    assert sorted(html.unescape(r) for r in rows) == sorted(ids)
    assert "Mean score" in page and "<b>3 students</b>: looks like paper" in page
    assert "<b>2 students</b>: read as linear: the PNG holds the values" in page
    for link in re.findall(r'<a href="(students/[^"]+)">page</a>', page):
        assert (out / html.unescape(link)).is_file()
    # Only the template's own script, allowed by its hash.
    assert page.count("<script>") == 1 and "script-src 'sha256-" in page


def test_effect_points_add_up_to_the_score(graded: tuple[Path, str]) -> None:
    from compare.grading.class_page import class_rows
    from compare.grading.results import read_result

    out, _ = graded
    results = [read_result(p) for p in sorted((out / "results").glob("*.json"))]
    effects, rows = class_rows([r for r in results if r is not None])
    assert {"refraction", "shadow", "background"} <= set(effects)
    for row in rows:
        if row["points"]:
            assert sum(row["points"].values()) == pytest.approx(row["score"], abs=1e-6)
    eve = next(r for r in rows if r["student"] == "eve")
    assert eve["points"]["shadow"] < 1 and eve["cause"].startswith("looks like paper")


def _browser():  # type: ignore[no-untyped-def]
    return chromium_browser()


def _heading(page, name: str):  # type: ignore[no-untyped-def]
    """A column heading's sort button."""
    return page.locator("#class-table thead button").filter(has_text=re.compile(f"^{name}$"))


def _column(page, n: int) -> list[str]:  # type: ignore[no-untyped-def]
    return list(
        page.eval_on_selector_all(
            f"#class-table tbody tr td:nth-child({n})", "cells => cells.map(c => c.textContent)"
        )
    )


def test_class_page_sorts_by_mouse_and_keyboard_and_links_work(
    graded: tuple[Path, str],
) -> None:
    out, _ = graded
    p, browser = _browser()
    try:
        page = browser.new_page(viewport={"width": 1400, "height": 900})
        errors: list[str] = []
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto((out / "index.html").as_uri())
        _heading(page, "score").click()
        scores = [float(x) for x in _column(page, 3)]
        assert scores == sorted(scores) and scores[0] < scores[-1]
        _heading(page, "score").click()  # again: reversed
        assert [float(x) for x in _column(page, 3)] == sorted(scores, reverse=True)
        head = page.locator("#class-table th", has_text="score").first
        assert head.get_attribute("aria-sort") == "descending"
        _heading(page, "student").focus()
        page.keyboard.press("Enter")
        names = _column(page, 1)
        assert names == sorted(names, key=str) and HOSTILE in names  # shown as text
        page.keyboard.press("Tab")  # the next heading, sorted with the space bar
        page.keyboard.press(" ")
        assert _column(page, 2) == sorted(_column(page, 2))
        ARTIFACTS.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(ARTIFACTS / "class.png"), full_page=True)
        row = page.locator("#class-table tbody tr", has_text="eve").first
        row.get_by_role("link", name="page").click()
        page.wait_for_load_state("load")
        assert page.url.endswith("/students/eve/index.html")
        assert page.title().startswith("eve: fail")
    finally:
        browser.close()
        p.stop()
    assert not errors, errors


def test_scores_csv_is_id_and_score_and_inert(graded: tuple[Path, str]) -> None:
    out, _ = graded
    book = _book(out)
    with (out / "scores.csv").open() as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["id", "score"] and len(rows) == len(book) + 1
    scores = dict(rows[1:])
    assert scores["'" + FORMULA] == book["'" + FORMULA]["score"]  # never a formula
    assert scores["alice"] == "100.00" and scores["dave"] == "0.00"


def test_gradescope_results_per_student_follow_the_format(graded: tuple[Path, str]) -> None:
    out, _ = graded
    book = _book(out)
    for sid in ("alice", "eve", "dave"):
        data = json.loads((out / "gradescope" / sid / "results.json").read_text())
        assert data["score"] == pytest.approx(float(book[sid]["score"]), abs=0.005)
        tests = data["tests"]
        assert {"score", "max_score", "name", "output", "visibility", "status"} <= set(tests[0])
        assert sum(t["max_score"] for t in tests) == pytest.approx(100, abs=0.05)
        assert sum(t["score"] for t in tests) == pytest.approx(data["score"], abs=0.05)
        assert all(0 <= t["score"] <= t["max_score"] for t in tests)
    eve = json.loads((out / "gradescope" / "eve" / "results.json").read_text())
    shadow = next(t for t in eve["tests"] if t["name"] == "classic: shadow")
    assert shadow["status"] == "failed" and "px (100 %) differ from classic" in shadow["output"]
    assert "looks like paper" in eve["output"]
    dave = json.loads((out / "gradescope" / "dave" / "results.json").read_text())
    assert [t["name"] for t in dave["tests"]] == ["classic: not judged"]
    assert dave["tests"][0]["output"].startswith("unreadable")


def test_gradescope_numbers_are_finite_and_in_range() -> None:
    from compare.grading.lms import gradescope_json
    from compare.grading.results import StudentResult

    r = StudentResult("x", "k", "fail", float("nan"), "classic", "", "", (), "r", float("inf"), "")
    data = json.loads(gradescope_json(r, "hidden"))
    assert data["score"] == 0.0 and data["execution_time"] == 0 and data["visibility"] == "hidden"
    with pytest.raises(ValueError, match="visibility"):
        gradescope_json(r, "public")


def test_gradescope_mode_grades_the_autograders_layout(subs: Path, tmp_path: Path) -> None:
    root = tmp_path / "autograder"
    (root / "submission").mkdir(parents=True)
    shutil.copyfile(subs / "carol.png", root / "submission" / "classic.png")
    os.mkfifo(root / "submission" / "notes.txt")  # never read: a copy would hang on it
    out = tmp_path / "out"
    proc = run(
        [RTVAL, "grade", "--gradescope", "--gradescope-root", str(root), *ARGS, "--out", str(out)],
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    data = json.loads((root / "results" / "results.json").read_text())
    assert data["score"] == 100.0 and data["output"].startswith("PASS")
    assert all(t["status"] == "passed" for t in data["tests"])
    assert str(root / "results" / "results.json") in proc.stdout
    # A submission with nothing to grade is the student's result (score 0, why).
    os.unlink(root / "submission" / "classic.png")
    proc = run(
        [RTVAL, "grade", "--gradescope", "--gradescope-root", str(root), *ARGS, "--out", str(out)]
    )
    assert proc.returncode == 0, proc.stderr
    data = json.loads((root / "results" / "results.json").read_text())
    assert data["score"] == 0 and "no image for scene 'classic'" in data["tests"][0]["output"]
    # A link is copied as a link, never followed, and refused as in any class.
    (root / "submission" / "classic.png").symlink_to(subs / "carol.png")
    proc = run(
        [RTVAL, "grade", "--gradescope", "--gradescope-root", str(root), *ARGS, "--out", str(out)]
    )
    assert proc.returncode == 0, proc.stderr
    data = json.loads((root / "results" / "results.json").read_text())
    assert data["score"] == 0 and "symbolic link" in data["tests"][0]["output"]


def test_gradescope_mode_names_the_student_from_the_metadata(subs: Path, tmp_path: Path) -> None:
    root = tmp_path / "autograder"
    (root / "submission").mkdir(parents=True)
    shutil.copyfile(subs / "carol.png", root / "submission" / "classic.png")
    fixture = Path(__file__).resolve().parent / "gradescope" / "submission_metadata.json"
    shutil.copyfile(fixture, root / "submission_metadata.json")  # Gradescope's documented shape
    out = tmp_path / "out"
    proc = run(
        [RTVAL, "grade", "--gradescope", "--gradescope-root", str(root), *ARGS, "--out", str(out)],
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    group = "ada@example.edu+alan@example.edu"
    assert f"gradescope: student {group} (Ada Student, Alan Student), from " in proc.stderr
    assert "submission_metadata.json: users[].email" in proc.stderr
    with (out / "gradebook.csv").open() as f:
        assert [row["student"] for row in csv.DictReader(f)] == [group]
    assert json.loads((root / "results" / "results.json").read_text())["score"] == 100.0


def test_gradescope_mode_without_the_layout_writes_no_result(tmp_path: Path) -> None:
    proc = run([RTVAL, "grade", "--gradescope", "--gradescope-root", str(tmp_path), *ARGS])
    assert proc.returncode != 0 and "no submission folder" in proc.stderr
    assert not (tmp_path / "results").exists()


def test_a_png_of_linear_codes_passes_and_says_so(graded: tuple[Path, str]) -> None:
    out, _ = graded
    carol, bob = _book(out)["carol"], _book(out)["bob"]
    assert carol["status"] == "pass" and carol["score"] == "100.00"
    note = "read as linear: the PNG holds the values a PPM writer stores"
    assert carol["reasons"] == f"classic: {note}"
    assert bob["status"] == "pass" and bob["reasons"] == ""  # an sRGB PNG: nothing to say
    verdict = json.loads((out / "results" / "carol.json").read_text())["scenes"][0]["verdict"]
    assert verdict["encoding"] == "linear" and verdict["encoding_note"] == note


def test_a_failing_png_of_linear_codes_is_diagnosed_as_what_it_is(
    graded: tuple[Path, str],
) -> None:
    """Read as sRGB, paper mode's linear codes look like nothing the demo renders; read as
    linear they are paper mode, the same diagnosis as eve's PPM of the same pixels."""
    out, _ = graded
    book = _book(out)
    frank, eve = book["frank"], book["eve"]
    assert frank["status"] == "fail" and frank["score"] == eve["score"]
    assert frank["diagnosis"] == eve["diagnosis"] and frank["diagnosis"].startswith(
        "looks like paper"
    )
    assert frank["reasons"].startswith("classic: read as linear: the PNG holds")
    results = json.loads((out / "gradescope" / "carol" / "results.json").read_text())
    assert "\nNote: classic: read as linear" in results["output"]


def test_test_encoding_fixes_the_encoding(subs: Path, tmp_path: Path) -> None:
    _grade(subs, tmp_path / "srgb", "--test-encoding", "srgb", "--no-diagnose")
    book = _book(tmp_path / "srgb")
    assert book["carol"]["status"] == "fail" and book["bob"]["status"] == "pass"
    assert "read as" not in book["carol"]["reasons"]
    _grade(subs, tmp_path / "linear", "--test-encoding", "linear", "--no-diagnose")
    book = _book(tmp_path / "linear")
    assert book["carol"]["status"] == "pass" and book["bob"]["status"] == "fail"
    assert book["alice"]["status"] == "pass"  # a PPM is linear anyway


def _links(page: str) -> list[str]:
    return [html.unescape(x) for x in re.findall(r'(?:href|src|data-[ab])="([^"]*)"', page)]


def test_student_pages_teach_and_link_only_inside_their_folder(graded: tuple[Path, str]) -> None:
    out, _ = graded
    for folder in (out / "students").iterdir():
        page = (folder / "index.html").read_text()
        for link in _links(page):
            assert link.startswith("#") or ("/" not in link and (folder / link).is_file()), link
    eve = (out / "students" / "eve" / "index.html").read_text()
    assert 'src="classic-model.png"' in eve and 'data-b="classic.png"' in eve
    assert "in display (sRGB) values, ×8" in eve and "No pixel differs" not in eve
    result = json.loads((out / "results" / "eve.json").read_text())
    effects = result["scenes"][0]["verdict"]["effects"]
    for name, e in effects.items():  # each reason once, beside its effect
        for reason in e["reasons"]:
            assert eve.count(html.escape(reason, quote=False)) == 1, reason
        assert f'<a href="#effect-{name}">{name}</a>' in eve and f'id="effect-{name}"' in eve
    shares = re.findall(r"<td>([0-9.]+) of ([0-9.]+)</td>", eve)
    assert sum(float(p) for p, _ in shares) == pytest.approx(result["score"], abs=0.1)
    assert sum(float(m) for _, m in shares) == pytest.approx(100, abs=0.1)
    assert eve.count("looks like paper") == 1 and 'id="quirk-2"' in eve
    # The difference lights only the pixels that differ; 8-bit rounding is no difference.
    lit = np.asarray(PILImage.open(out / "students" / "eve" / "classic-diff.png")).any(axis=2)
    assert 0 < lit.sum() <= result["scenes"][0]["verdict"]["exact"]["differing"]
    assert not np.asarray(PILImage.open(out / "students" / "alice" / "classic-diff.png")).any()
    carol = (out / "students" / "carol" / "index.html").read_text()
    assert "No pixel differs" in carol and "classic-diff.png" not in carol
    assert "read as linear: the PNG holds the values a PPM writer stores" in carol
    assert "gradebook" not in carol  # nothing of the class's


def test_the_flip_control_works_by_mouse_and_keyboard(graded: tuple[Path, str]) -> None:
    out, _ = graded
    p, browser = _browser()
    try:
        page = browser.new_page(viewport={"width": 1200, "height": 900})
        errors: list[str] = []
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto((out / "students" / "eve" / "index.html").as_uri())
        img, state = page.locator("img.flip"), page.locator(".flip-state")
        assert img.get_attribute("src") == "classic-model.png"
        img.hover()
        assert img.get_attribute("src") == "classic.png" and state.text_content() == "your image"
        page.mouse.move(1190, 890)
        assert img.get_attribute("src") == "classic-model.png"
        img.focus()
        page.keyboard.press(" ")  # pinned on the student's image
        assert img.get_attribute("src") == "classic.png"
        page.keyboard.press("Enter")
        assert img.get_attribute("src") == "classic-model.png"
        assert page.evaluate("Array.from(document.images).every(i => i.naturalWidth > 0)")
        ARTIFACTS.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(ARTIFACTS / "student.png"), full_page=True)
    finally:
        browser.close()
        p.stop()
    assert not errors, errors


def test_handout_folders_are_the_pages_and_all_they_show(
    subs: Path, graded: tuple[Path, str]
) -> None:
    out, stdout = graded
    handout = subs.parent / "handout"
    assert str(handout) in stdout
    assert sorted(f.name for f in handout.iterdir()) == sorted(
        f.name for f in (out / "students").iterdir()
    )
    for folder in handout.iterdir():
        page = (folder / "index.html").read_text()
        assert page == (out / "students" / folder.name / "index.html").read_text()
        assert all(not f.is_symlink() for f in folder.iterdir())
        for link in _links(page):
            assert link.startswith("#") or (folder / link).is_file(), link


def test_a_marked_pixel_opens_the_models_ray_tree_by_mouse_and_keyboard(
    graded: tuple[Path, str],
) -> None:
    out, _ = graded
    assert "The model's rays" not in (out / "students" / "alice" / "index.html").read_text()
    p, browser = _browser()
    try:
        page = browser.new_page(viewport={"width": 1200, "height": 900})
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        # a script the Content-Security-Policy refused is a console error
        page.on("console", lambda m: m.type == "error" and errors.append(m.text))
        page.goto((out / "students" / "eve" / "index.html").as_uri())
        marks, trees = page.locator("a.ray-mark"), page.locator("details.ray-tree")
        assert marks.count() == trees.count() == 8
        assert not trees.nth(0).evaluate("d => d.open")
        # the tree opens on the hashchange event, after the click returns: wait for it
        marks.nth(0).click()
        first = trees.nth(0)
        expect(first).to_have_js_property("open", True)
        text = first.inner_text()
        assert "camera ray" in text and "returns" in text and "your image (" in text
        assert any(name in text for name in ("ground", "glass", "gold", "blue", "silver"))
        marks.nth(3).focus()
        page.keyboard.press("Enter")
        expect(trees.nth(3)).to_have_js_property("open", True)
    finally:
        browser.close()
        p.stop()
    assert not errors, errors


def test_a_noisy_ppm_is_read_as_linear_and_its_noise_named(tmp_path: Path, rtdemo: str) -> None:
    """Noise matches a few more pixels by chance read as sRGB, but looks far nearer read as
    the PPM it is (bench_grade.py's noisy students were told "the PPM holds sRGB values")."""
    folder = tmp_path / "subs"
    folder.mkdir()
    right = render_demo(rtdemo, SCENES / "classic.json", tmp_path / "r.exr", "--mode", "classic",
                        "-q", size=(160, 120))  # fmt: skip
    rgb = np.clip(np.nan_to_num(right.rgb), 0, 1)
    noisy = rgb + np.random.default_rng(5).normal(0, 0.01, rgb.shape)
    codes = np.floor(255 * np.clip(noisy, 0, 1)).astype(np.uint8)
    (folder / "gina.ppm").write_bytes(b"P6\n160 120\n255\n" + codes.tobytes())
    _grade(folder, tmp_path / "out")
    gina = _book(tmp_path / "out")["gina"]
    assert gina["status"] == "fail" and "read as sRGB" not in gina["reasons"], gina
    assert "random noise on every pixel" in gina["diagnosis"], gina
