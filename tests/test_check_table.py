"""`rtval check --against MODEL`'s table: a case judged by exact match shows a largest error
that agrees with its failing pixels (an error over the differing pixels, none when none
differ), in the terminal and in the JSON."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from helpers import SCENES, run

RTVAL = str(Path(sys.executable).with_name("rtval"))


def test_exact_match_rows_have_an_error_where_pixels_fail(tmp_path: Path) -> None:
    js = tmp_path / "c.json"
    proc = run(
        [RTVAL, "check", "--scenes", str(SCENES / "classic.json"), "--against", "classic",
         "--modes", "paper,classic", "--size", "48x36", "--json", str(js)]
    )  # fmt: skip
    assert proc.returncode == 2, proc.stderr
    rows = {line.split()[0]: line.split() for line in proc.stdout.splitlines()[1:3]}
    paper, classic = rows["classic/cpu-paper"], rows["classic/cpu-classic"]
    assert paper[1] == "fail" and int(paper[2]) > 0 and float(paper[3]) > 0.1
    assert classic[1:4] == ["pass", "0", "0.0000"]
    cases = {c["name"]: c for c in json.loads(js.read_text())["cases"]}
    assert abs(cases["classic/cpu-paper"]["max_display_error"] - float(paper[3])) < 1e-4
    assert cases["classic/cpu-paper"]["failing_pixels"] == int(paper[2])
