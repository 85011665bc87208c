"""`rtval report` with a hostile --label and --test-image file name: the page shows them as
text, runs only its own script (CSP by hash; data as inert JSON), the figures show `$` as
`$`, and the PDF is printed from a copy without any script."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import SCENES, run

pytestmark = pytest.mark.slow
RTVAL = str(Path(sys.executable).with_name("rtval"))
LABEL = '</script><script>document.title="pwned";window.pwned=1</script> $\\alpha$ & <b>x'
IMAGE_NAME = "<img src=x onerror=window.pwned=2>$a$.ppm"


@pytest.fixture(scope="module")
def page(tmp_path_factory: pytest.TempPathFactory, rtdemo: str) -> Path:
    root = tmp_path_factory.mktemp("hostile-report")
    image = root / IMAGE_NAME
    cmd = [rtdemo, "render", str(SCENES / "classic.json"), "--ppm", str(image), "-q"]
    assert run([*cmd, "--mode", "classic", "--width", "64", "--height", "48"]).returncode == 0
    proc = run(
        [
            RTVAL,
            "report",
            str(SCENES / "classic.json"),
            "--reports-dir",
            str(root / "out"),
            "--size",
            "64x48",
            "--test-image",
            str(image),
            "--label",
            LABEL,
        ]
    )
    assert proc.returncode == 0, proc.stderr
    return root / "out" / "classic"


def test_page_shows_the_label_as_text_and_runs_none_of_it(page: Path) -> None:
    from playwright.sync_api import sync_playwright

    html = (page / "index.html").read_text(encoding="utf-8")
    assert LABEL not in html and "</script><script>" not in html
    assert 'http-equiv="Content-Security-Policy"' in html and "script-src 'sha256-" in html
    chromium = shutil.which("chromium")
    assert chromium
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
        pg = browser.new_page()
        errors: list[str] = []
        pg.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        pg.on("pageerror", lambda e: errors.append(str(e)))
        pg.on("dialog", lambda d: errors.append("dialog " + d.message))
        pg.goto((page / "index.html").as_uri())
        pg.wait_for_load_state("load")
        assert pg.title() == "rtval report: classic"
        assert pg.evaluate("window.pwned") is None
        assert LABEL in pg.evaluate("document.body.textContent")
        assert pg.eval_on_selector_all("#flip-a option", "os => os.length") >= 2  # own script ran
        browser.close()
    assert not errors, errors  # no CSP violation: the page's own script and images are allowed


def test_pdf_printed_without_scripts_and_nothing_left_behind(page: Path) -> None:
    text = subprocess.run(
        ["pdftotext", str(page / "report.pdf"), "-"], capture_output=True, text=True, check=True
    ).stdout
    assert "pwned" in text  # the label, printed as text
    assert not [p.name for p in page.iterdir() if p.name.startswith(".") or ".tmp" in p.name]


def test_figure_titles_show_dollars_literally() -> None:
    from compare.escape import mathtext_literal

    # matplotlib would render $\alpha$ as a Greek letter and raise on an odd number of $
    assert mathtext_literal("a $x$ b $") == "a \\$x\\$ b \\$"
