"""Hypothesis: the Python scene loader and the image readers never fail any other way than
with their own error (SceneError, ImageError) on arbitrary input."""

from __future__ import annotations

import contextlib
import json
import struct
from pathlib import Path

import hypothesis.strategies as st
import numpy as np
from hypothesis import HealthCheck, given, settings

from compare.judge.images import ImageError, read_image
from scene_model.scene import SceneError, parse_scene

json_values = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(10**6), 10**6)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=12),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=10), inner, max_size=4)
    ),
    max_leaves=20,
)

SPHERE_KEYS = ["name", "center", "radius", "color", "reflection", "transparency", "ior", "emission"]


@st.composite
def almost_scenes(draw: st.DrawFn) -> str:
    """Valid-looking scenes with some values replaced by arbitrary JSON."""
    scene: dict[str, object] = {
        "format": "rtval-scene/1",
        "name": "fuzz",
        "spheres": [{"name": "a", "center": [0, 0, -5], "radius": 1, "color": [1, 1, 1]}],
    }
    for _ in range(draw(st.integers(0, 4))):
        target = draw(st.sampled_from(["top", "sphere", "camera"]))
        key = draw(
            st.sampled_from(
                ["format", "name", "bias", "max_depth", "background", "camera", "extra"]
                if target == "top"
                else SPHERE_KEYS
                if target == "sphere"
                else ["position", "look_at", "up", "fov_y", "width", "height"]
            )
        )
        value = draw(json_values)
        if target == "top":
            scene[key] = value
        elif target == "sphere":
            scene["spheres"][0][key] = value  # type: ignore[index]
        else:
            cam = scene.setdefault("camera", {})
            if isinstance(cam, dict):
                cam[key] = value
    return json.dumps(scene)


@settings(max_examples=400, deadline=None)
@given(almost_scenes())
def test_loader_only_raises_scene_error(text: str) -> None:
    try:
        parse_scene(text, "fuzz.json")
    except SceneError as e:
        assert str(e).startswith("fuzz.json: ")


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=200) | st.text(max_size=200).map(str.encode))
def test_loader_on_arbitrary_bytes(data: bytes) -> None:
    with contextlib.suppress(SceneError):
        parse_scene(data.decode("utf-8", errors="replace"), "bytes.json")


HEADERS = {
    ".ppm": [b"P6\n4 4\n255\n", b"P6\n100000 100000\n255\n", b"P3\n2 2\n255\n"],
    ".png": [b"\x89PNG\r\n\x1a\n"],
    ".exr": [b"\x76\x2f\x31\x01\x02\x00\x00\x00"],
    ".pfm": [b"PF\n4 4\n-1.0\n", b"Pf\n2 2\n1.0\n", b"PF\n-3 4\n-1\n"],
}


@settings(
    max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    suffix=st.sampled_from(sorted(HEADERS)), which=st.integers(0, 2), tail=st.binary(max_size=300)
)
def test_image_readers_only_raise_image_error(
    tmp_path: Path, suffix: str, which: int, tail: bytes
) -> None:
    header = HEADERS[suffix][which % len(HEADERS[suffix])]
    path = tmp_path / f"fuzz{suffix}"
    path.write_bytes(header + tail)
    try:
        img = read_image(path)
        assert img.rgb.ndim == 3 and img.rgb.shape[2] == 3
    except ImageError as e:
        assert str(path) in str(e)


@settings(
    max_examples=50, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(w=st.integers(1, 9), h=st.integers(1, 9), seed=st.integers(0, 2**31))
def test_pfm_round_trip(tmp_path: Path, w: int, h: int, seed: int) -> None:
    img = np.random.default_rng(seed).normal(size=(h, w, 3)).astype(np.float32)
    path = tmp_path / "x.pfm"
    path.write_bytes(b"PF\n%d %d\n-1.0\n" % (w, h) + img[::-1].astype("<f4").tobytes())
    np.testing.assert_array_equal(read_image(path).rgb, img)
    assert struct.calcsize("<f") == 4
