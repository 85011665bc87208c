"""The one page writer (compare/pages/writer.py) and the one PNG encoder (compare/judge/png.py):
the encodings of finite images are the ones each caller wrote before, a non-finite pixel is the
marker colour everywhere, and every page carries its CSP and escapes what it prints."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from PIL import Image as PILImage

from compare.judge.images import linear_to_srgb
from compare.judge.png import FAST, MARKER, display_values, encode_png, write_linear_png
from compare.pages.writer import render_page, write_page


def _decode(data: bytes) -> np.ndarray:
    return np.asarray(PILImage.open(io.BytesIO(data)).convert("RGB"))


def _old_encoding(display: np.ndarray, level: int) -> bytes:
    """What grade.py and images.write_png wrote: clamped, rounded codes."""
    buf = io.BytesIO()
    codes = np.round(np.clip(display, 0, 1) * 255).astype(np.uint8)
    PILImage.fromarray(codes, "RGB").save(buf, format="PNG", compress_level=level)
    return buf.getvalue()


@pytest.mark.parametrize("level", [FAST, 6])
def test_finite_images_encode_as_before(level: int) -> None:
    rng = np.random.default_rng(3)
    linear = rng.uniform(-0.2, 1.3, (17, 23, 3)).astype(np.float32)
    display = linear_to_srgb(linear)
    assert encode_png(display, compress_level=level) == _old_encoding(display, level)
    assert np.array_equal(display_values(linear), display)


def test_every_non_finite_pixel_is_the_marker(tmp_path: Path) -> None:
    linear = np.full((4, 5, 3), 0.25, np.float32)
    linear[0, 0, 1] = np.nan
    linear[1, 2, 0] = np.inf
    linear[3, 4, 2] = -np.inf
    write_linear_png(tmp_path / "x.png", linear)
    codes = np.asarray(PILImage.open(tmp_path / "x.png").convert("RGB"))
    bad = np.zeros((4, 5), bool)
    bad[0, 0] = bad[1, 2] = bad[3, 4] = True
    assert (codes[bad] == MARKER).all()
    assert (codes[~bad] == codes[1, 1]).all() and tuple(codes[1, 1]) != MARKER
    # A display-space picture (a difference map) keeps the mark too.
    diff = np.clip(np.abs(display_values(linear) - 0.5) * 8, 0, 1)
    assert (_decode(encode_png(diff))[bad] == MARKER).all()


def test_only_rgb_images_are_encoded() -> None:
    with pytest.raises(ValueError, match="H x W x 3"):
        encode_png(np.zeros((4, 5)))


def test_pages_carry_the_csp_and_escape(tmp_path: Path) -> None:
    r = {
        "student": "<img src=x onerror=alert(1)>",
        "status": "fail",
        "score": 0.0,
        "model": "classic",
        "rubric": "default rubric",
        "diagnosis": "",
        "scenes": [],
    }
    page = render_page("student.html.j2", r=r)
    assert page.count('http-equiv="Content-Security-Policy"') == 1
    assert "script-src 'none'" in page
    assert "<img src=x" not in page and "&lt;img src=x onerror=alert(1)&gt;" in page
    write_page(tmp_path / "index.html", "student.html.j2", r=r)
    assert (tmp_path / "index.html").read_text(encoding="utf-8") == page


def test_a_page_never_replaces_a_link(tmp_path: Path) -> None:
    victim = tmp_path / "victim.txt"
    victim.write_text("keep")
    (tmp_path / "index.html").symlink_to(victim)
    with pytest.raises(OSError, match="symbolic link"):
        write_page(tmp_path / "index.html", "check.html.j2", cases=[], total=0, failed=0)
    assert victim.read_text() == "keep"


def test_the_step_summary_shows_user_text_literally() -> None:
    """A case named after a path with `![x](https://...)` showed a picture in GitHub's step
    summary; every Markdown metacharacter of user text is escaped."""
    from compare.check import run as check
    from compare.check.output import markdown_summary

    name = "![x](https://evil.example/p.png)"
    r = check.CaseResult("classic", name, "default", "fail", renderer="t")
    r.reasons = [f"classic: render failed: [link](https://e.x) *bold* _it_ `code` ~~s~~ {name}"]
    r.failed_effects = ["render"]
    text = markdown_summary([r])
    assert "![" not in text and "](" not in text and "`code`" not in text
    assert "\\!\\[x\\]\\(https://evil.example/p.png\\)" in text
    assert "\\*bold\\* \\_it\\_ \\`code\\` \\~\\~s\\~\\~" in text
