"""tolerances.json as docs/check.md describes it: `null` is "no limit" for every field, and an
invalid file is an unreadable input (exit 4, naming the file), not a bad argument (64)."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest
from helpers import SCENES, run

from compare.check.run import TolerancesFileError, load_tolerances

RTVAL = str(Path(sys.executable).with_name("rtval"))


def test_null_means_no_limit(tmp_path: Path) -> None:
    fields = ("fail", "failpercent", "warn", "warnpercent", "hardfail", "min_ssim", "max_flip")
    (tmp_path / "tolerances.json").write_text(json.dumps({"paper": dict.fromkeys(fields)}))
    t = load_tolerances(tmp_path)["paper"]
    assert (t.fail, t.warn, t.hardfail) == (1.0, 1.0, math.inf)  # no display error exceeds 1
    assert (t.failpercent, t.warnpercent, t.min_ssim, t.max_flip) == (100.0, 100.0, None, None)


@pytest.mark.parametrize(
    "text", ["{", '{"paper": {"fail": -1}}', '{"paper": {"fial": 0.1}}', '{"paper": 3}', "[]"]
)
def test_an_invalid_file_names_itself_and_exits_4(tmp_path: Path, text: str) -> None:
    (tmp_path / "tolerances.json").write_text(text)
    with pytest.raises(TolerancesFileError, match=r"tolerances\.json: invalid tolerances"):
        load_tolerances(tmp_path)
    scene = str(SCENES / "classic.json")
    proc = run(
        [RTVAL, "check", "--baseline", str(tmp_path), "--scenes", scene, "--modes", "classic"]
    )
    assert proc.returncode == 4, proc.stdout + proc.stderr
    assert "tolerances.json: invalid tolerances" in proc.stderr
