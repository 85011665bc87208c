"""The quick EXR reader (compare/judge/exr_scanlines.py) gives what OpenEXR gives on every
layout rtdemo writes, hands every other layout to OpenEXR, and refuses what it must refuse
before reading pixels."""

from __future__ import annotations

import struct
import subprocess
from pathlib import Path

import numpy as np
import OpenEXR
import pytest

from compare.judge import exr_scanlines, images
from compare.judge.images import ImageError, ImageSizeError, read_image

SCENE = Path(__file__).resolve().parents[1] / "scenes" / "classic.json"


def _render(rtdemo: str, out: Path, *extra: str) -> Path:
    cmd = [rtdemo, "render", str(SCENE), "-o", str(out), "-q", "--width", "37", "--height", "23"]
    subprocess.run([*cmd, *extra], check=True)
    return out


def _quick(path: Path) -> exr_scanlines.Scanlines | None:
    with path.open("rb") as f:
        layout = exr_scanlines.read_layout(f)
    return None if layout is None else exr_scanlines.parse(layout, path.read_bytes())


def _same(a: images.Image, b: images.Image) -> None:
    assert a.rgb.dtype == b.rgb.dtype == np.float32 and a.rgb.flags.c_contiguous
    assert a.rgb.tobytes() == b.rgb.tobytes()
    assert list(a.aovs) == list(b.aovs)
    for k in a.aovs:
        assert a.aovs[k].shape == b.aovs[k].shape and a.aovs[k].tobytes() == b.aovs[k].tobytes()
    assert list(a.header.items()) == list(b.header.items())
    assert (a.encoding, a.path) == (b.encoding, b.path)


@pytest.mark.parametrize(
    "extra",
    [(), ("--keep-frame",), ("--spp", "4", "--mode", "physical"), ("--mode", "paper")],
    ids=["streamed", "kept-frame", "spp4", "paper"],
)
def test_rtdemo_exrs_read_as_openexr_reads_them(rtdemo: str, tmp_path: Path, extra: tuple) -> None:
    exr = _render(rtdemo, tmp_path / "r.exr", *extra)
    assert _quick(exr) is not None  # the quick reader takes it
    _same(read_image(exr), images._read_exr(exr))
    assert read_image(exr).header["rtval.renderer"] == "rtdemo"


@pytest.mark.parametrize("compression", ["zip", "rle"])
def test_compressed_exrs_go_to_openexr(rtdemo: str, tmp_path: Path, compression: str) -> None:
    exr = _render(rtdemo, tmp_path / "r.exr", "--exr-compression", compression)
    assert _quick(exr) is None
    plain = _render(rtdemo, tmp_path / "p.exr")
    a, b = read_image(exr), read_image(plain)
    assert a.rgb.tobytes() == b.rgb.tobytes() and a.aovs["id"].tobytes() == b.aovs["id"].tobytes()


@pytest.mark.parametrize("extra", [(), ("--exr-compression", "zip")])
def test_only_the_aovs_asked_for_are_read(rtdemo: str, tmp_path: Path, extra: tuple) -> None:
    """Both readers (the plain layout's and OpenEXR's) keep the AOVs named, the pixels as
    they are."""
    exr = _render(rtdemo, tmp_path / "r.exr", *extra)
    every, some = read_image(exr), read_image(exr, aovs=("id", "depth"))
    assert set(every.aovs) == {"id", "depth", "N.X", "N.Y", "N.Z"}
    assert set(some.aovs) == {"id", "depth"}
    assert some.rgb.tobytes() == every.rgb.tobytes()
    assert all(some.aovs[k].tobytes() == every.aovs[k].tobytes() for k in some.aovs)
    assert read_image(exr, aovs=()).aovs == {}


def _write(path: Path, channels: dict[str, np.ndarray], compression: object) -> None:
    """(OpenEXR.File turns the dict's arrays into its own Channel objects.)"""
    header = {"compression": compression, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, channels) as f:
        f.write(str(path))


def test_half_channels_and_other_writers(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    rgb = rng.random((5, 7, 3), dtype=np.float32)
    planes = [np.ascontiguousarray(rgb[..., i]) for i in range(3)]
    plain = tmp_path / "plain.exr"
    _write(plain, dict(zip("RGB", planes, strict=True)), OpenEXR.NO_COMPRESSION)
    assert _quick(plain) is not None
    _same(read_image(plain), images._read_exr(plain))
    half = tmp_path / "half.exr"
    halves = [p.astype(np.float16) for p in planes]
    _write(half, dict(zip("RGB", halves, strict=True)), OpenEXR.NO_COMPRESSION)
    assert _quick(half) is None
    assert np.allclose(read_image(half).rgb, rgb, atol=1e-3)


def test_a_truncated_file_is_refused_naming_it(rtdemo: str, tmp_path: Path) -> None:
    exr = _render(rtdemo, tmp_path / "r.exr")
    data = exr.read_bytes()
    cut = tmp_path / "cut.exr"
    cut.write_bytes(data[: len(data) - 100])
    assert _quick(cut) is None
    with pytest.raises(ImageError, match=r"cut\.exr"):
        read_image(cut)


def test_lines_out_of_order_are_not_taken(rtdemo: str, tmp_path: Path) -> None:
    exr = _render(rtdemo, tmp_path / "r.exr")
    with exr.open("rb") as f:
        layout = exr_scanlines.read_layout(f)
    assert layout is not None
    data = bytearray(exr.read_bytes())
    first = layout.table_at + 8 * layout.height
    struct.pack_into("<i", data, first, 5)  # line 0's block says it is line 5
    assert exr_scanlines.parse(layout, bytes(data)) is None


def test_the_size_is_checked_before_the_pixels(rtdemo: str, tmp_path: Path) -> None:
    exr = _render(rtdemo, tmp_path / "r.exr")
    with pytest.raises(ImageSizeError, match="wrong size 37x23, expected 40x30"):
        read_image(exr, expected_size=(30, 40))
    # A header declaring a huge data window is refused before anything is allocated.
    data = bytearray(exr.read_bytes())
    at = data.index(b"dataWindow\0box2i\0") + len("dataWindow\0box2i\0") + 4
    struct.pack_into("<iiii", data, at, 0, 0, 20000, 20000)
    huge = tmp_path / "huge.exr"
    huge.write_bytes(bytes(data))
    with pytest.raises(ImageError, match="at most"):
        read_image(huge)
