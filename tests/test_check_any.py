"""`rtval check --renderer`: two foreign programs under the regression check, one in Python
(tests/foreign/pytracer.py, the classic algorithm in numpy) and one in C++
(tests/foreign/classic_tracer.cpp, compiled here), each with a switch that breaks shadows."""

from __future__ import annotations

import json
import os
import select
import shlex
import shutil
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from helpers import ROOT, SCENES, chromium_browser, run
from playwright.sync_api import expect

from compare.check import run as check
from compare.render import foreign
from scene_model.scene import load_scene

RTVAL = str(Path(sys.executable).with_name("rtval"))
FOREIGN = ROOT / "tests" / "foreign"
PYTRACER = f"{shlex.quote(sys.executable)} {FOREIGN / 'pytracer.py'} {{scene}} {{out}} {{width}} {{height}}"
SIZE = "160x120"
BREAK = {"RTVAL_TEST_BREAK": "shadows"}


def _rtval(*args: str, env: dict[str, str] | None = None) -> tuple[int, str]:
    proc = run([RTVAL, "check", "--size", SIZE, *args], env={**os.environ, **(env or {})})
    return proc.returncode, proc.stdout + proc.stderr


@pytest.fixture(scope="module")
def cpp_tracer(tmp_path_factory: pytest.TempPathFactory) -> Path:
    compiler = shutil.which("g++") or shutil.which("c++")
    if compiler is None:
        pytest.fail("no C++ compiler (g++) on PATH: the C++ foreign renderer cannot be built")
    exe = tmp_path_factory.mktemp("cpp") / "classic_tracer"
    proc = run([compiler, "-O2", "-std=c++17", "-o", str(exe), str(FOREIGN / "classic_tracer.cpp")])
    assert proc.returncode == 0, proc.stderr
    return exe


def _junit_failures(path: Path) -> dict[tuple[str, str], str]:
    suite = ET.parse(path).getroot()
    out = {}
    for case in suite.iter("testcase"):
        failure = case.find("failure")
        if failure is not None:
            out[(case.get("classname", ""), case.get("name", ""))] = failure.get("message", "")
    return out


def _ray_tree_opens(page_file: Path) -> None:
    """The diagnosis' model's ray trees at differing pixels: a numbered mark, clicked, opens
    its tree; focused, Enter opens another (Chromium, as a user does)."""
    p, browser = chromium_browser()
    try:
        page = browser.new_page()
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        # a script the Content-Security-Policy refused is a console error
        page.on("console", lambda m: m.type == "error" and errors.append(m.text))
        page.goto(page_file.as_uri())
        marks, trees = page.locator("a.ray-mark"), page.locator("details.ray-tree")
        assert marks.count() == trees.count() > 1
        # the tree opens on the hashchange event, after the click returns: wait for it
        marks.nth(0).click()
        expect(trees.nth(0)).to_have_js_property("open", True)
        assert "camera ray" in trees.nth(0).inner_text()
        marks.nth(1).focus()
        page.keyboard.press("Enter")
        expect(trees.nth(1)).to_have_js_property("open", True)
        assert not errors, errors
    finally:
        browser.close()
        p.stop()


def _regression_cycle(tmp_path: Path, renderer: list[str], name: str, scenes: list[str]) -> None:
    """--update writes baselines, an unchanged re-run passes, a build without shadows fails
    with exit 2 naming scene and effect in the terminal, JSON, JUnit, HTML and the summary."""
    base = tmp_path / "baselines"
    code, out = _rtval("--baseline", str(base), "--scenes", *scenes, *renderer, "--update")
    assert code == 0, out
    stems = [Path(s).stem for s in scenes]
    assert f"baselines written: {', '.join(f'{name}/{s}' for s in stems)}" in out
    written = {s: (base / name / s / "default.exr").stat().st_mtime_ns for s in stems}

    code, out = _rtval("--baseline", str(base), "--scenes", *scenes, *renderer, "--update")
    assert code == 0 and "baselines written" not in out and "replaced" not in out, out
    assert {s: (base / name / s / "default.exr").stat().st_mtime_ns for s in stems} == written

    junit, html, js, summary = (
        tmp_path / "j.xml",
        tmp_path / "html",
        tmp_path / "c.json",
        tmp_path / "summary.md",
    )
    summary.write_text("earlier step\n")
    code, out = _rtval(
        "--baseline",
        str(base),
        "--scenes",
        *scenes,
        *renderer,
        "--junit",
        str(junit),
        "--html",
        str(html),
        "--json",
        str(js),
        env={**BREAK, "GITHUB_STEP_SUMMARY": str(summary)},
    )
    assert code == 2, out
    assert "classic: shadow FLIP" in out
    failures = _junit_failures(junit)
    assert failures[(f"rtval.{name}.classic", "shadow")].startswith("classic: shadow FLIP")
    # Direct light and the background are untouched by a missing shadow test.
    assert (f"rtval.{name}.classic", "direct") not in failures
    assert (f"rtval.{name}.classic", "background") not in failures
    data = json.loads(js.read_text())
    assert data["status"] == "fail"
    case = next(c for c in data["cases"] if c["scene"] == "classic")
    assert case["failed_effects"][0] == "shadow" and case["effects"]["shadow"]["flip"] > 0.3
    assert case["effects"]["direct"]["status"] == "pass"
    page = (html / "index.html").read_text()
    assert f"{name}/classic" in page and "classic: shadow FLIP" in page
    # The diagnosis slot (compare.diagnose.search) names the switch that reproduces the bug.
    assert "<h3>Diagnosis</h3>" in page and "looks like classic --no-shadows" in page
    assert "Content-Security-Policy" in page
    _ray_tree_opens(html / "index.html")
    for kind in ("reference", "render", "difference", "flip"):
        assert (html / "images" / f"case000-{kind}.png").stat().st_size > 100
    text = summary.read_text()
    assert text.startswith("earlier step\n") and "rtval check: FAIL" in text and "shadow" in text


def test_python_renderer_under_check(tmp_path: Path) -> None:
    scenes = [str(SCENES / "classic.json"), str(SCENES / "paper.json")]
    _regression_cycle(
        tmp_path, ["--renderer", PYTRACER, "--output-format", "pfm"], "pytracer", scenes
    )


def test_cpp_renderer_under_check(tmp_path: Path, cpp_tracer: Path) -> None:
    renderer = [
        "--renderer",
        f"{cpp_tracer} {{out}} {{width}} {{height}}",
        "--output-format",
        "ppm",
    ]
    _regression_cycle(
        tmp_path,
        [*renderer, "--renderer-name", "cpp-classic"],
        "cpp-classic",
        [str(SCENES / "classic.json")],
    )


def test_against_the_classic_model_without_baselines(tmp_path: Path, cpp_tracer: Path) -> None:
    # Exact match (compare/judge/exact_match.py), no tolerances.json: the C++ program's
    # truncating 8-bit PPM is one of the two writers exact match accepts.
    scene = str(SCENES / "classic.json")
    cpp = ["--renderer", f"{cpp_tracer} {{out}} {{width}} {{height}}", "--output-format", "ppm"]
    args = ["--baseline", str(tmp_path), "--scenes", scene, "--against", "classic", *cpp]
    code, out = _rtval(*args)
    assert code == 0 and "against classic" in out, out
    code, out = _rtval(*args, env=BREAK)
    assert code == 2 and "classic: shadow FLIP" in out, out
    assert "px (100 %) differ from classic beyond 8-bit linear quantisation" in out, out
    assert not list(tmp_path.iterdir())  # nothing written where baselines would be
    # The float64 numpy program is within half-float precision of rtdemo's float32 everywhere
    # but where rays graze a silhouette or a chain of mirrors more closely than one value:
    # there it lies within the spread of the model's renders with the camera turned by 1e-4
    # and 1e-3 px. Measured at 160x120: 1 reflection pixel of 4,896 is outside even that,
    # within the allowance (4), so the program passes.
    js = tmp_path / "c.json"
    py = ["--renderer", PYTRACER, "--output-format", "pfm", "--json", str(js)]
    code, out = _rtval("--scenes", scene, "--against", "classic", *py)
    (case,) = json.loads(js.read_text())["cases"]
    assert code == 0 and case["status"] == "pass", out
    assert sum(e["failing_pixels"] for e in case["effects"].values()) <= 2
    code, out = _rtval("--scenes", scene, "--against", "classic+Q99", "--renderer", PYTRACER)
    assert code == 64 and "--against" in out, out
    code, out = _rtval("--scenes", scene, "--against", "classic", "--spp", "4", *cpp)
    assert code == 64 and "--spp 1 only" in out, out


def test_a_renderer_with_no_size_option_is_checked_at_the_scenes_size(
    tmp_path: Path, cpp_tracer: Path
) -> None:
    # scratchapixel's program has no size option: it always writes 640x480, the classic
    # scene's own size, and without --size check renders the scene at that size.
    scene = str(SCENES / "classic.json")
    fixed = ["--renderer", f"{cpp_tracer} {{out}} 640 480", "--output-format", "ppm"]
    js = tmp_path / "c.json"
    proc = run([RTVAL, "check", "--scenes", scene, "--against", "classic", *fixed, "--json",
                str(js)])  # fmt: skip
    assert proc.returncode == 0, proc.stdout + proc.stderr
    (case,) = json.loads(js.read_text())["cases"]
    assert case["size"] == [640, 480] and case["status"] == "pass"
    # Asked for another size, which it cannot render, it fails saying what to do.
    code, out = _rtval("--scenes", scene, "--against", "classic", *fixed)  # --size 160x120
    assert code == 2 and "image is 640x480, expected 160x120" in out, out
    assert "leave out --size to render at the scene's size" in out


def test_without_size_a_case_renders_at_its_baselines_size(
    tmp_path: Path, cpp_tracer: Path
) -> None:
    scene = str(SCENES / "classic.json")
    scalable = ["--renderer", f"{cpp_tracer} {{out}} {{width}} {{height}}", "--output-format",
                "ppm", "--renderer-name", "cpp"]  # fmt: skip
    base = ["--baseline", str(tmp_path), "--scenes", scene, *scalable]
    code, out = _rtval(*base, "--update")  # written at 160x120
    assert code == 0 and "baselines written: cpp/classic" in out, out
    js = tmp_path / "c.json"
    proc = run([RTVAL, "check", *base, "--json", str(js)])
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert json.loads(js.read_text())["cases"][0]["size"] == [160, 120]
    # With no baseline (a first --update), the scene's own size.
    settings = check.CheckSettings(scenes=[scene], baseline_dir=tmp_path / "none")
    classic = load_scene(scene)
    assert check.case_size(settings, classic, tmp_path / "none.exr") == ((640, 480), "scene")
    settings.size = (96, 72)
    assert check.case_size(settings, classic, None) == ((96, 72), "--size")


def test_rtdemo_against_its_own_model_and_another(tmp_path: Path) -> None:
    scene = str(SCENES / "classic.json")
    code, out = _rtval("--baseline", str(tmp_path), "--scenes", scene, "--against", "classic")
    assert code == 0 and "classic/cpu-classic" in out, out
    # The paper's program is not the classic one: Q2 (eta inside glass) shows in refraction.
    code, out = _rtval(
        "--baseline", str(tmp_path), "--scenes", scene, "--against", "classic", "--modes", "paper"
    )
    assert code == 2 and "classic/cpu-paper: refraction FLIP" in out, out


def _settings(tmp_path: Path, template: str, **kw: object) -> check.CheckSettings:
    return check.CheckSettings(
        scenes=[str(SCENES / "classic.json")],
        baseline_dir=tmp_path,
        size=(32, 24),
        renderer=foreign.parse_command(template, kw.pop("name", "t"), str(kw.pop("fmt", "exr"))),
        **kw,  # type: ignore[arg-type]
    )


PY = shlex.quote(sys.executable)


@pytest.mark.parametrize(
    "template,fmt,expected",
    [
        (f"{PY} -c pass {{out}}", "exr", "wrote no image"),
        (
            f"{PY} -c \"import sys; print('boom <script>', file=sys.stderr); sys.exit(3)\" {{out}}",
            "exr",
            "exit status 3",
        ),
        (f"{PY} -c \"open('{{out}}', 'w').write('junk')\"", "exr", 'wrote text ("junk")'),
        (
            f"{PY} {FOREIGN / 'pytracer.py'} {{scene}} {{out}} {{height}} {{width}}",
            "pfm",
            "image is 24x32, expected 32x24",
        ),
    ],
)
def test_renderer_failures_are_clear_case_failures(
    tmp_path: Path, template: str, fmt: str, expected: str
) -> None:
    results = check.run_check(_settings(tmp_path, template, fmt=fmt), progress=lambda _: None)
    (r,) = results
    assert r.status == "fail" and r.failed_effects == ["render"], r.reasons
    assert expected in r.reasons[0] and r.reasons[0].startswith("classic: render failed")
    if "boom" in template:
        assert "renderer stderr:\nboom <script>" in r.reasons[0]
        from compare.check.html import write_html

        page = write_html(results, tmp_path / "html").read_text()
        assert "boom &lt;script&gt;" in page and "boom <script>" not in page
    assert check.exit_code(results) == 2


def test_timeout_kills_the_renderer_and_its_children(tmp_path: Path) -> None:
    marker, pid_file = tmp_path / "child-survived", tmp_path / "child.pid"
    # The renderer starts a child that says its pid, then would write the marker after 60 s;
    # both must die at the 1 s timeout.
    child = (
        f"import os, time; open({str(pid_file)!r}, 'w').write(str(os.getpid())); "
        f"time.sleep(60); open({str(marker)!r}, 'w')"
    )
    parent = (
        f"import subprocess, sys, time, os; subprocess.Popen([sys.executable, '-c', {child!r}]); "
        f"[time.sleep(0.01) for _ in iter(lambda: os.path.exists({str(pid_file)!r}), True)]; "
        "time.sleep(60)"
    )
    template = f"{PY} -c {shlex.quote(parent)} {{out}}"
    start = time.perf_counter()
    (r,) = check.run_check(_settings(tmp_path, template, timeout=1.0), progress=lambda _: None)
    assert time.perf_counter() - start < 20
    assert r.status == "fail" and "timed out after 1 s" in r.reasons[0]
    assert pid_file.exists()  # the child was running when the timeout struck
    assert _gone(int(pid_file.read_text())), "the renderer's child outlived the timeout"
    assert not marker.exists()


def _gone(pid: int, within: float = 30.0) -> bool:
    """True once the process has ended: its pidfd turns readable then (an event, not a poll)."""
    try:
        fd = os.pidfd_open(pid)
    except ProcessLookupError:
        return True
    try:
        return bool(select.select([fd], [], [], within)[0])
    finally:
        os.close(fd)


def test_mode_placeholder_and_scene_xml(tmp_path: Path) -> None:
    # A renderer reading the Mitsuba export: the XML exists while it runs and is gone after.
    seen = tmp_path / "seen.txt"
    script = (
        "import sys, shutil; xml, out, mode = sys.argv[1:4]; "
        f"open({str(seen)!r}, 'a').write(mode + ' ' + xml + ' ' + str('<scene' in open(xml).read()) + chr(10)); "
        f"shutil.copy({str(ROOT / 'tests' / 'baselines' / 'classic' / 'classic.exr')!r}, out)"
    )
    template = f"{PY} -c {shlex.quote(script)} {{scene_xml}} {{out}} {{mode}}"
    settings = _settings(tmp_path, template, modes=["paper", "classic"], update=True)
    settings.size = (320, 240)
    results = check.run_check(settings, progress=lambda _: None)
    assert [r.mode for r in results] == ["paper", "classic"]
    assert (tmp_path / "t" / "classic" / "paper.exr").is_file()
    lines = seen.read_text().splitlines()
    assert [ln.split()[0] for ln in lines] == ["paper", "classic"]
    assert all(ln.endswith("True") for ln in lines)
    assert not any(Path(ln.split()[1]).exists() for ln in lines)


@pytest.mark.parametrize(
    "args,message",
    [
        (["--renderer", "prog {nope} {out}"], "unknown placeholder {nope}"),
        (["--renderer", "prog {scene}"], "must write the image {out}"),
        (["--renderer", "prog 'unclosed {out}"], "No closing quotation"),
        (["--renderer", "prog {out}", "--renderer-name", "a/b"], "--renderer-name"),
        (["--timeout", "5"], "need --renderer"),
        (
            ["--renderer", "prog {out}", "--against", "classic", "--update"],
            "there are none to write",
        ),
        (["--renderer", "prog {out}", "--timeout", "-1"], "--timeout"),
    ],
)
def test_bad_renderer_options_exit_64(args: list[str], message: str) -> None:
    code, out = _rtval(*args)
    assert code == 64 and message in out, out


def test_default_renderer_names() -> None:
    assert foreign.renderer_name(["python3", "tools/my_tracer.py", "{scene}"]) == "my_tracer"
    assert foreign.renderer_name(["./build/tracer", "{scene}", "{out}"]) == "tracer"
    assert foreign.renderer_name(["/usr/bin/env", "node", "{scene}"]) == "node"


def test_pytest_fixture_checks_a_scene_in_one_line(tmp_path: Path) -> None:
    (tmp_path / "test_render.py").write_text(
        "def test_classic(rtval_check):\n"
        f"    rtval_check({str(SCENES / 'classic.json')!r}, renderer={PYTRACER!r},\n"
        "                output_format='pfm', size=(96, 72))\n"
    )
    env = {**os.environ, "PYTEST_DISABLE_PLUGIN_AUTOLOAD": "1", "PYTHONPATH": str(ROOT)}
    cmd = [
        sys.executable,
        "-m",
        "pytest",
        "-p",
        "compare.pytest_plugin",
        "-q",
        "-p",
        "no:cacheprovider",
    ]
    first = run(cmd, cwd=tmp_path, env=env)
    assert (
        first.returncode == 1 and "no baseline" in first.stdout and "--rtval-update" in first.stdout
    )
    assert run([*cmd, "--rtval-update"], cwd=tmp_path, env=env).returncode == 0
    assert (tmp_path / "rtval-baselines" / "pytracer" / "classic" / "default.exr").is_file()
    again = run(cmd, cwd=tmp_path, env=env)
    assert again.returncode == 0, again.stdout
    broken = run(cmd, cwd=tmp_path, env={**env, **BREAK})
    assert broken.returncode == 1 and "classic: shadow FLIP" in broken.stdout, broken.stdout


def test_first_look_without_flip_matches_the_full_evaluation() -> None:
    import numpy as np

    from compare.judge.evaluate import evaluate_pair

    rng = np.random.default_rng(3)
    ref = rng.uniform(0, 1, (40, 48, 3)).astype(np.float32)
    test = ref.copy()
    test[5:9, 5:9] += 0.2
    cheap = evaluate_pair(ref, test, flip=False)
    full = evaluate_pair(ref, test)
    assert np.isnan(cheap.metrics.flip_ldr) and full.metrics.flip_ldr > 0
    assert cheap.verdict == full.verdict and cheap.metrics.ssim == full.metrics.ssim


def test_markdown_summary_escapes_user_text() -> None:
    from compare.check.output import markdown_summary

    r = check.CaseResult("classic", "t", "default", "fail", renderer="t")
    r.reasons = ["classic: render failed: <img src=x> | a\nrenderer stderr:\nmore"]
    r.failed_effects = ["render"]
    text = markdown_summary([r])
    assert "<img" not in text and "- classic: render failed: &lt;img src=x&gt; \\| a" in text
    assert "| t/classic | ❌ fail | render |" in text


def test_outputs_hold_hostile_text_and_a_failed_diagnosis_is_a_note(tmp_path: Path) -> None:
    import numpy as np

    from compare.check.html import write_html
    from compare.check.output import write_json, write_junit

    r = check.CaseResult("classic", "t", "default", "fail", renderer="t")
    r.reasons = ["classic: render failed: \x01<script>alert(1)</script>"]
    r.failed_effects = ["render"]
    write_junit([r], tmp_path / "j.xml")
    failures = _junit_failures(tmp_path / "j.xml")  # parses: no control character
    # No image was made: the image testcase fails too (it was marked passed).
    assert sorted(name for _, name in failures) == ["image", "render"]
    assert all("\x01" not in f and "<script>" in f for f in failures.values())
    write_json([r], tmp_path / "c.json")
    assert json.loads((tmp_path / "c.json").read_text())["status"] == "fail"
    # A diagnosis that cannot be made (the scene file is gone) leaves a note, not a traceback.
    pic = np.zeros((4, 4, 3), np.float32)
    r.pictures = check.FailurePictures(pic, pic, pic[..., 0])
    r.scene_file = str(tmp_path / "gone.json")
    notes: list[str] = []
    page = write_html([r], tmp_path / "html", note=notes.append).read_text()
    assert len(notes) == 1 and notes[0].startswith("no diagnosis for t/classic")
    assert "no diagnosis for t/classic" in page and "<script>alert" not in page
    # Outputs never replace what is not a regular file, nor name a scene.
    os.mkfifo(tmp_path / "fifo")
    code, out = _rtval("--renderer", "prog {out}", "--json", str(tmp_path / "fifo"))
    assert code == 4 and "regular file" in out, out
    scene = str(SCENES / "classic.json")
    code, out = _rtval("--scenes", scene, "--renderer", "prog {out}", "--junit", scene)
    assert code == 64 and "--junit names the same file as --scenes" in out, out
