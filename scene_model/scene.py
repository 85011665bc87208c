"""Loader for rtval-scene/1 files (docs/scene-format.md), the Python twin of demo_cpp's loader.

Every rule of the format is enforced; an error names the file, the JSON path and what was
expected, e.g. ``scenes/x.json: spheres[3].radius: expected a finite number > 0, got -1``.
Numbers are checked as the renderers will hold them, in float32 (a radius of 1e-50 is 0 there,
a fov of 179.9999999 is 180), so that this loader and the C++ one accept the same files.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from safe_files.paths import read_bounded

Vec3 = tuple[float, float, float]

FORMAT = "rtval-scene/1"
FLOAT32_MAX = 3.4028234663852886e38
_NAME_RULE = re.compile(r"[a-z0-9_-]{1,64}")  # it becomes part of file names
MAX_SCENE_BYTES = 16 << 20  # the built-in scenes are ~2 KB; a stress scene ~100 KB
MAX_NESTING = 64
_BOM = "\ufeff"
_STRUCTURE = re.compile(r'"(?:[^"\\]|\\.)*"|[\[\]{}]')  # a whole string, or a bracket
_CONTROL = re.compile(r"[\x00-\x1f\x7f]")


class SceneError(ValueError):
    """An invalid scene file; the message names file, JSON path and expectation."""


@dataclass(frozen=True)
class Camera:
    position: Vec3 = (0.0, 0.0, 0.0)
    look_at: Vec3 = (0.0, 0.0, -1.0)
    up: Vec3 = (0.0, 1.0, 0.0)
    fov_y: float = 30.0
    width: int = 640
    height: int = 480


@dataclass(frozen=True)
class Sphere:
    name: str
    center: Vec3
    radius: float
    color: Vec3
    reflection: float = 0.0
    transparency: float = 0.0
    ior: float = 1.1
    emission: Vec3 = (0.0, 0.0, 0.0)

    @property
    def kind(self) -> str:
        """light, glass, mirror or diffuse: the class that decides the Mitsuba material."""
        if any(e > 0 for e in self.emission):
            return "light"
        if self.transparency > 0:
            return "glass"
        if self.reflection > 0:
            return "mirror"
        return "diffuse"


@dataclass(frozen=True)
class Scene:
    name: str
    spheres: tuple[Sphere, ...]
    camera: Camera = field(default_factory=Camera)
    background: Vec3 = (2.0, 2.0, 2.0)
    max_depth: int = 5
    bias: float = 1e-4
    description: str = ""
    source: str = ""

    @property
    def lights(self) -> list[int]:
        return [i for i, s in enumerate(self.spheres) if s.kind == "light"]


class _Checker:
    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, path: str, expected: str, got: Any = ...) -> SceneError:
        msg = f"{self.source}: {path or '(top level)'}: {expected}"
        if got is not ...:
            msg += f", got {json.dumps(got)}"
        return SceneError(msg)

    def only_keys(self, obj: dict[str, Any], path: str, allowed: tuple[str, ...]) -> None:
        for key in obj:
            if key not in allowed:
                where = f"{path}.{key}" if path else key
                raise self.fail(where, "unknown key; expected one of: " + ", ".join(allowed))

    def number(self, v: Any, path: str, rule: str, ok: Callable[[float], bool]) -> float:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.fail(path, f"expected a number {rule}".rstrip(), v)
        f = float(v)
        f32 = f
        if math.isfinite(f):
            with np.errstate(over="ignore"):
                f32 = float(np.float32(f))  # as the renderers hold it (may round to inf)
        if not math.isfinite(f32) or not ok(f32):
            raise self.fail(path, f"expected a finite number {rule}".rstrip(), v)
        return f  # the file's own number: exports and pages show 1.2, not 1.2000000476837158

    def triple(self, v: Any, path: str, rule: str, ok: Callable[[float], bool]) -> Vec3:
        if not isinstance(v, list) or len(v) != 3:
            raise self.fail(path, f"expected an array of 3 numbers {rule}".rstrip(), v)
        a, b, c = (self.number(x, f"{path}[{i}]", rule, ok) for i, x in enumerate(v))
        return (a, b, c)

    def integer(self, v: Any, path: str, lo: int, hi: int) -> int:
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            raise self.fail(path, f"expected an integer from {lo} to {hi}", v)
        return v

    def string(self, v: Any, path: str) -> str:
        if not isinstance(v, str):
            raise self.fail(path, "expected a string", v)
        try:
            v.encode("utf-8")
        except UnicodeEncodeError:  # a lone UTF-16 surrogate, which UTF-8 cannot hold
            raise self.fail(path, "expected Unicode text (a lone surrogate is not)") from None
        return v


def _any(_: float) -> bool:
    return True


def _non_negative(f: float) -> bool:
    return f >= 0


def _parse_camera(j: Any, c: _Checker) -> Camera:
    if not isinstance(j, dict):
        raise c.fail("camera", "expected an object", j)
    c.only_keys(j, "camera", ("position", "look_at", "up", "fov_y", "width", "height"))
    d = Camera()
    cam = Camera(
        position=c.triple(j["position"], "camera.position", "", _any)
        if "position" in j
        else d.position,
        look_at=c.triple(j["look_at"], "camera.look_at", "", _any) if "look_at" in j else d.look_at,
        up=c.triple(j["up"], "camera.up", "", _any) if "up" in j else d.up,
        fov_y=c.number(j["fov_y"], "camera.fov_y", "in (0, 180) degrees", lambda f: 0 < f < 180)
        if "fov_y" in j
        else d.fov_y,
        width=c.integer(j["width"], "camera.width", 1, 16384) if "width" in j else d.width,
        height=c.integer(j["height"], "camera.height", 1, 16384) if "height" in j else d.height,
    )
    _check_view(cam, c)
    return cam


def _dot32(a: NDArray[np.float32], b: NDArray[np.float32]) -> np.float32:
    """x*x + y*y + z*z in float32, in the C++ order."""
    return np.float32(np.float32(a[0] * b[0]) + np.float32(a[1] * b[1])) + np.float32(a[2] * b[2])


def _check_view(cam: Camera, c: _Checker) -> None:
    """The C++ loader's test, in float32 as it computes it: a view direction whose length is
    neither zero (nor underflows to it) nor overflows, and an up that is not parallel to it."""
    f32 = np.float32
    with np.errstate(all="ignore"):
        view = np.array(cam.look_at, f32) - np.array(cam.position, f32)
        up = np.array(cam.up, f32)
        vv, uu = _dot32(view, view), _dot32(up, up)
        if not (0 < vv < np.inf):
            raise c.fail("camera.look_at", "expected a point different from camera.position")
        forward = view / np.sqrt(vv)
        side = np.array(
            [
                forward[1] * up[2] - forward[2] * up[1],
                forward[2] * up[0] - forward[0] * up[2],
                forward[0] * up[1] - forward[1] * up[0],
            ],
            f32,
        )
        if not (0 < uu < np.inf and np.sqrt(_dot32(side, side)) >= f32(1e-6) * np.sqrt(uu)):
            raise c.fail("camera.up", "expected a direction not parallel to the view direction")


def _parse_sphere(j: Any, path: str, c: _Checker) -> Sphere:
    if not isinstance(j, dict):
        raise c.fail(path, "expected an object", j)
    c.only_keys(
        j,
        path,
        ("name", "center", "radius", "color", "reflection", "transparency", "ior", "emission"),
    )
    for req in ("name", "center", "radius", "color"):
        if req not in j:
            raise c.fail(f"{path}.{req}", "missing; expected this required key")
    name = c.string(j["name"], f"{path}.name")
    if not name:
        raise c.fail(f"{path}.name", "expected a non-empty string", name)
    if _CONTROL.search(name):  # names land in XML, HTML and file names
        raise c.fail(f"{path}.name", "expected a name without control characters", name)
    return Sphere(
        name=name,
        center=c.triple(j["center"], f"{path}.center", "", _any),
        radius=c.number(j["radius"], f"{path}.radius", "> 0", lambda f: f > 0),
        color=c.triple(j["color"], f"{path}.color", ">= 0", _non_negative),
        reflection=c.number(j["reflection"], f"{path}.reflection", ">= 0", _non_negative)
        if "reflection" in j
        else 0.0,
        transparency=c.number(
            j["transparency"], f"{path}.transparency", "from 0 to 1", lambda f: 0 <= f <= 1
        )
        if "transparency" in j
        else 0.0,
        ior=c.number(j["ior"], f"{path}.ior", ">= 1", lambda f: f >= 1) if "ior" in j else 1.1,
        emission=c.triple(j["emission"], f"{path}.emission", ">= 0", _non_negative)
        if "emission" in j
        else (0.0, 0.0, 0.0),
    )


def _parse_int(digits: str) -> int | float:
    """An integer beyond 64 bits is read as a float, as nlohmann json (the C++ loader) does:
    a huge one becomes inf, which the checks refuse naming the field, instead of an
    OverflowError (or Python's digit-limit ValueError) escaping."""
    if len(digits.lstrip("-")) > 19:
        return float(digits)
    return int(digits)


def _nesting_depth(text: str) -> int:
    """The deepest nesting of [ and { outside strings. json.loads recurses once per level
    and would end in a RecursionError; a scene needs 4 levels."""
    depth = deepest = 0
    for m in _STRUCTURE.finditer(text):
        tok = m.group()
        if tok in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif tok in "]}":
            depth -= 1
    return deepest


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not valid JSON")


def _decode_json(text: str, source: str) -> Any:
    """The JSON value of ``text``, refusing what the C++ loader would read differently."""
    # RFC 8259 lets a parser ignore a leading byte order mark; the C++ loader (nlohmann
    # json) skips it, so this one does too: both accept the same files.
    text = text.removeprefix(_BOM)
    if "\0" in text:
        raise SceneError(f"{source}: invalid JSON: contains a NUL byte")
    depth = _nesting_depth(text)
    if depth > MAX_NESTING:
        raise SceneError(
            f"{source}: invalid JSON: nested {depth} levels deep, at most {MAX_NESTING} allowed"
        )
    try:
        return json.loads(text, parse_constant=_reject_constant, parse_int=_parse_int)
    except json.JSONDecodeError as e:
        raise SceneError(
            f"{source}: invalid JSON at line {e.lineno}, column {e.colno}: {e.msg}"
        ) from None
    except ValueError as e:
        raise SceneError(f"{source}: invalid JSON: {e}") from None


def _parse_header(root: Any, c: _Checker) -> str:
    """Checks the root's keys and format; returns the scene's name."""
    if not isinstance(root, dict):
        raise c.fail("", "expected a JSON object")
    c.only_keys(
        root,
        "",
        ("format", "name", "description", "camera", "background", "max_depth", "bias", "spheres"),
    )
    if "format" not in root:
        raise c.fail("format", f'missing; expected "{FORMAT}"')
    if root["format"] != FORMAT:
        raise c.fail("format", f'expected exactly "{FORMAT}"', root["format"])
    if "name" not in root:
        raise c.fail("name", "missing; expected a name of 1-64 characters [a-z0-9_-]")
    name = c.string(root["name"], "name")
    if not _NAME_RULE.fullmatch(name):
        raise c.fail("name", "expected a name of 1-64 characters [a-z0-9_-]", name)
    return name


def _parse_spheres(root: dict[str, Any], c: _Checker) -> tuple[Sphere, ...]:
    if "spheres" not in root:
        raise c.fail("spheres", "missing; expected an array of spheres")
    if not isinstance(root["spheres"], list):
        raise c.fail("spheres", "expected an array", root["spheres"])
    spheres: list[Sphere] = []
    seen: set[str] = set()
    for i, j in enumerate(root["spheres"]):
        s = _parse_sphere(j, f"spheres[{i}]", c)
        if s.name in seen:
            raise c.fail(f"spheres[{i}].name", f'expected a unique name; "{s.name}" is used twice')
        seen.add(s.name)
        spheres.append(s)
    return tuple(spheres)


def parse_scene(text: str, source: str = "<string>") -> Scene:
    """Parses and validates scene JSON text; ``source`` names it in errors."""
    root = _decode_json(text, source)
    c = _Checker(source)
    name = _parse_header(root, c)
    description = c.string(root["description"], "description") if "description" in root else ""
    camera = _parse_camera(root["camera"], c) if "camera" in root else Camera()
    background = (
        c.triple(root["background"], "background", ">= 0", _non_negative)
        if "background" in root
        else (2.0, 2.0, 2.0)
    )
    max_depth = c.integer(root["max_depth"], "max_depth", 0, 64) if "max_depth" in root else 5
    bias = c.number(root["bias"], "bias", "> 0", lambda f: f > 0) if "bias" in root else 1e-4
    return Scene(
        name=name,
        spheres=_parse_spheres(root, c),
        camera=camera,
        background=background,
        max_depth=max_depth,
        bias=bias,
        description=description,
        source=source,
    )


def load_scene(path: str | Path) -> Scene:
    """Reads and validates a scene file: a regular file (never a FIFO, which would block,
    or a device such as a symlink to /dev/zero, which never ends) of at most
    MAX_SCENE_BYTES, UTF-8 with or without a BOM."""
    p = Path(path)
    try:
        raw = read_bounded(p, MAX_SCENE_BYTES)
    except OSError as e:
        raise SceneError(f"cannot read the scene file: {e}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise SceneError(f"{p}: not UTF-8 text: {e}") from None
    return parse_scene(text, str(p))
