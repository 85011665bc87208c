"""`rtval report` writes a complete report folder."""

from __future__ import annotations

import json
from pathlib import Path

from conftest import SCENES, run


def test_report_writes_index_json_and_every_image(tmp_path: Path) -> None:
    import sys

    rtval = str(Path(sys.executable).with_name("rtval"))
    proc = run([rtval, "report", str(SCENES / "paper.json"), "--reports-dir", str(tmp_path),
                "--size", "64x48"])
    assert proc.returncode == 0, proc.stderr
    out = tmp_path / "paper"
    index = (out / "index.html").read_text()
    data = json.loads((out / "report.json").read_text())
    assert data["scene"] == "paper"
    assert len(data["renders"]) >= 3
    for r in data["renders"]:
        assert (out / r["png"]).stat().st_size > 0 and (out / r["exr"]).stat().st_size > 0
        assert f'src="{r["png"]}"' in index
        assert r["command_text"] in index.replace("&#39;", "'")
    assert "[3/3]" in proc.stderr  # progress
    assert not list(out.glob("*.tmp"))


def test_report_on_invalid_scene_is_exit_3(tmp_path: Path) -> None:
    import sys

    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "rtval-scene/1"}')
    rtval = str(Path(sys.executable).with_name("rtval"))
    proc = run([rtval, "report", str(bad), "--reports-dir", str(tmp_path)])
    assert proc.returncode == 3 and "bad.json: name" in proc.stderr
