"""The rtval command line's errors in words: the closest known command, choice or option for a
typo; inputs and output folders checked before anything is rendered; `check --update` saying
which baselines it wrote; a renderer's image of another format than --output-format named from
its first bytes."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest
from helpers import SCENES, run

from compare.cli.common import error_words

RTVAL = str(Path(sys.executable).with_name("rtval"))
CLASSIC = str(SCENES / "classic.json")
# A renderer that writes a binary PPM to {out}, whatever its name says.
PPM_WRITER = (
    "import sys; open(sys.argv[1], 'wb').write(b'P6\\n16 12\\n255\\n' + bytes(16 * 12 * 3))"
)


def _last_line(text: str) -> str:
    return text.strip().splitlines()[-1]


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["chek"], "invalid choice: 'chek' (choose from 'report', "),
        (["chek"], "(did you mean check?)"),
        (["check", "--udpate"], "rtval check: error: unrecognized arguments: --udpate (did you mean --update?)"),
        (["compare", "a.png", "b.png", "--test-encoding", "srbg"], "(did you mean srgb?)"),
        (["report", "classic", "--siez", "64x64"], "unrecognized arguments: --siez (did you mean --size?) 64x64"),
    ],
)  # fmt: skip
def test_a_typo_gets_the_closest_known_word(argv: list[str], said: str) -> None:
    proc = run([RTVAL, *argv])
    assert proc.returncode == 64
    assert said in _last_line(proc.stderr)
    assert proc.stdout == ""


def test_a_word_close_to_nothing_gets_no_suggestion() -> None:
    proc = run([RTVAL, "check", "--zzzzzz"])
    assert proc.returncode == 64
    assert _last_line(proc.stderr) == "rtval check: error: unrecognized arguments: --zzzzzz"


def test_an_os_error_is_said_as_path_and_reason() -> None:
    e = FileNotFoundError(2, "No such file or directory", "/no/such")
    assert error_words(e) == "/no/such: No such file or directory"
    assert error_words(OSError("x.json: cannot write")) == "x.json: cannot write"


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["check", "--scenes", CLASSIC, "--json", "{tmp}/none/x.json"],
         "--json {tmp}/none/x.json: cannot write: folder '{tmp}/none' does not exist"),
        (["check", "--scenes", CLASSIC, "--baseline", "{tmp}/file"], "--baseline {tmp}/file: not a folder"),
        (["check", "--scenes", CLASSIC, "--rtdemo", "{tmp}/none"],
         "--rtdemo {tmp}/none: no such program (an executable file)"),
        (["check", "--scenes", CLASSIC, "--renderer", "{tmp}/none {{out}}"],
         "--renderer: cannot run '{tmp}/none': no such executable file"),
        (["check", "--scenes", CLASSIC, "--renderer", "rtval-no-such-program {{out}}"],
         "--renderer: cannot run 'rtval-no-such-program': not found on PATH"),
        (["compare", "{tmp}/file.png", "{tmp}/file.png", "--diff-image", "{tmp}/none/d.png"],
         "--diff-image {tmp}/none/d.png: cannot write: folder '{tmp}/none' does not exist"),
    ],
)  # fmt: skip
def test_inputs_and_output_folders_are_checked_before_any_render(
    tmp_path: Path, argv: list[str], said: str
) -> None:
    (tmp_path / "file").write_text("x")
    (tmp_path / "file.png").write_text("x")
    proc = run([RTVAL, *(a.format(tmp=tmp_path) for a in argv)])
    assert proc.returncode == 4, proc.stderr
    assert proc.stderr == f"rtval: error: {said.format(tmp=tmp_path)}\n"  # nothing rendered first


def _update(baseline: Path, modes: str) -> tuple[int, str, str]:
    proc = run(
        [RTVAL, "check", "--baseline", str(baseline), "--scenes", CLASSIC, "--size", "16x12",
         "--modes", modes, "--update"]
    )  # fmt: skip
    return proc.returncode, proc.stdout, proc.stderr


def test_update_says_baselines_written_then_replaced(tmp_path: Path) -> None:
    code, out, err = _update(tmp_path, "physical")
    assert code == 0
    assert _last_line(out) == "0 passed, 0 failed, 1 baseline written"
    assert "classic/cpu-physical         written           -        -        -" in out
    assert "FAIL" not in err and "baselines written: classic/cpu-physical" in err

    (tmp_path / "classic" / "physical.exr").replace(tmp_path / "classic" / "paper.exr")
    code, out, err = _update(tmp_path, "paper,classic")
    assert code == 0
    assert _last_line(out) == "0 passed, 0 failed, 1 baseline written, 1 baseline replaced"
    assert "classic/cpu-paper            baseline replaced" in err and "it failed: " in err

    code, out, _ = _update(tmp_path, "paper,classic")
    assert code == 0 and _last_line(out) == "2 passed, 0 failed"


@pytest.mark.parametrize(("output_format", "hint"), [("exr", ": pass --output-format ppm"),
                                                     ("png", ": pass --output-format ppm")])  # fmt: skip
def test_a_wrong_output_format_is_named_from_the_first_bytes(
    tmp_path: Path, output_format: str, hint: str
) -> None:
    script = tmp_path / "ppm_writer.py"
    script.write_text(PPM_WRITER)
    proc = run(
        [RTVAL, "check", "--renderer", f"{sys.executable} {script} {{out}}", "--scenes", CLASSIC,
         "--size", "16x12", "--baseline", str(tmp_path / "b"), "--output-format", output_format]
    )  # fmt: skip
    assert proc.returncode == 2
    said = (
        f"classic: render failed: the renderer wrote a PPM (P6) but --output-format is "
        f"{output_format}{hint}"
    )
    assert f"  {said}\n" in proc.stdout
    assert "rtval-render-" not in proc.stdout + proc.stderr  # no temporary path


@pytest.mark.parametrize(
    ("text", "said"),
    [
        ('{"default": {"fial": 0.1}}', "invalid tolerances: 'default': unknown field 'fial' (did you mean fail?)"),
        ('{"default": {"fail": 0.1', "invalid tolerances: not JSON: expecting ',' delimiter at line 1, column 25"),
    ],
)  # fmt: skip
def test_a_bad_tolerances_file_is_said_in_words(tmp_path: Path, text: str, said: str) -> None:
    (tmp_path / "tolerances.json").write_text(text)
    proc = run([RTVAL, "check", "--baseline", str(tmp_path), "--scenes", CLASSIC])
    assert proc.returncode == 4
    assert proc.stderr == f"rtval: error: {tmp_path}/tolerances.json: {said}\n"


# grade and diagnose are left to their own modules' tests.
HELPED = ("report", "export", "reference", "compare", "ztest", "check", "stress", "cache")


@pytest.mark.parametrize("command", HELPED)
def test_help_texts_hold_no_slips(command: str) -> None:
    """No argparse escape printed as it is, and every file of ours a help names exists."""
    proc = run([RTVAL, command, "--help"])
    assert proc.returncode == 0
    text = " ".join(proc.stdout.split())  # paths may wrap
    assert "%%" not in text
    root = SCENES.parent
    for named in re.findall(r"\b(?:compare|docs|scene_model|demo_cpp)/[\w/.-]*\w", text):
        assert (root / named).exists(), named


def test_compare_against_warns_when_the_image_is_not_the_scenes_size(
    tmp_path: Path, rtdemo: str
) -> None:
    scene = json.loads((SCENES / "classic.json").read_text())
    scene["camera"].update(width=32, height=24)
    own = tmp_path / "small.json"
    own.write_text(json.dumps(scene))
    image = tmp_path / "t.ppm"
    for w, h in ((32, 24), (24, 18)):
        made = run([rtdemo, "render", str(own), "-o", str(image), "--mode", "classic", "-q",
                    "--width", str(w), "--height", str(h)])  # fmt: skip
        assert made.returncode == 0, made.stderr
        proc = run(
            [RTVAL, "compare", str(image), "--against", "classic", "--scene", str(own), "-q"]
        )
        assert proc.returncode == 0, proc.stderr
        warned = f"rtval: warning: {image} is 24x18; {own} renders at 32x24"
        assert (warned in proc.stderr) == ((w, h) != (32, 24)), proc.stderr
