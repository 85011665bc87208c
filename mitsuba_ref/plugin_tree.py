"""A tiny description of a Mitsuba scene that can be written as XML or as a load_dict dict,
so the file a user opens and the scene rendered from Python are the same by construction."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Union
from xml.sax.saxutils import quoteattr

from scene_model.scene import Vec3


@dataclass(frozen=True)
class RGB:
    value: Vec3


@dataclass(frozen=True)
class Color:
    """A colour property of a texture plugin (RGB is a texture standing for a colour)."""

    value: Vec3


@dataclass(frozen=True)
class Point:
    value: Vec3


@dataclass(frozen=True)
class LookAt:
    origin: Vec3
    target: Vec3
    up: Vec3


Value = Union[float, int, bool, str, RGB, Color, Point, LookAt, "Plugin"]


@dataclass
class Plugin:
    category: (
        str  # XML tag: scene, shape, bsdf, emitter, sensor, film, rfilter, sampler, integrator
    )
    type: str
    props: dict[str, Value] = field(default_factory=dict)
    id: str | None = None
    comment: str | None = None


def _fmt(x: float) -> str:
    return repr(float(x))


def _vec(v: Vec3) -> str:
    return ", ".join(_fmt(x) for x in v)


def to_xml(p: Plugin, indent: int = 0, name: str | None = None) -> str:
    """The plugin as XML; `name` is the property a nested texture stands for."""
    pad = "    " * indent
    lines: list[str] = []
    if p.comment:
        for c in p.comment.splitlines():
            lines.append(f"{pad}<!-- {c.replace('--', '- -')} -->")
    attrs = f' type="{p.type}"' if p.category != "scene" else ' version="3.0.0"'
    if p.id:
        attrs += f" id={quoteattr(p.id)}"
    if name:
        attrs += f" name={quoteattr(name)}"
    lines.append(f"{pad}<{p.category}{attrs}>")
    inner = "    " * (indent + 1)
    for name, v in p.props.items():
        n = quoteattr(name)
        if isinstance(v, Plugin):
            lines.append(to_xml(v, indent + 1, name if v.category == "texture" else None))
        elif isinstance(v, bool):
            lines.append(f'{inner}<boolean name={n} value="{str(v).lower()}"/>')
        elif isinstance(v, int):
            lines.append(f'{inner}<integer name={n} value="{v}"/>')
        elif isinstance(v, float):
            lines.append(f'{inner}<float name={n} value="{_fmt(v)}"/>')
        elif isinstance(v, str):
            lines.append(f"{inner}<string name={n} value={quoteattr(v)}/>")
        elif isinstance(v, (RGB, Color)):
            lines.append(f'{inner}<rgb name={n} value="{_vec(v.value)}"/>')
        elif isinstance(v, Point):
            lines.append(f'{inner}<point name={n} value="{_vec(v.value)}"/>')
        elif isinstance(v, LookAt):
            lines.append(f"{inner}<transform name={n}>")
            lines.append(
                f'{inner}    <lookat origin="{_vec(v.origin)}" target="{_vec(v.target)}" '
                f'up="{_vec(v.up)}"/>'
            )
            lines.append(f"{inner}</transform>")
        else:  # pragma: no cover - the tree is built by export.py only
            raise TypeError(f"cannot write {name}={v!r} as XML")
    lines.append(f"{pad}</{p.category}>")
    return "\n".join(lines)


def to_dict(p: Plugin, mi: Any) -> dict[str, Any]:
    d: dict[str, Any] = {"type": p.type}
    if p.id:
        d["id"] = p.id
    for name, v in p.props.items():
        if isinstance(v, Plugin):
            d[name] = to_dict(v, mi)
        elif isinstance(v, RGB):
            d[name] = {"type": "rgb", "value": list(v.value)}
        elif isinstance(v, Color):
            d[name] = mi.ScalarColor3f(*v.value)
        elif isinstance(v, Point):
            d[name] = mi.ScalarPoint3f(*v.value)
        elif isinstance(v, LookAt):
            d[name] = mi.ScalarTransform4f().look_at(
                origin=list(v.origin), target=list(v.target), up=list(v.up)
            )
        else:
            d[name] = v
    return d
