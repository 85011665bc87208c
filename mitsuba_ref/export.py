"""rtval-scene/1 -> Mitsuba 3 scene, as XML (for Mitsuba's own loader) and as a dict.

Mapping (also written into the XML as comments):
  diffuse -> `diffuse`, reflectance = colour
  glass   -> `dielectric`, int_ior = ior, ext_ior = 1, specular_reflectance = colour,
             specular_transmittance = colour * transparency (the paper's weights, exact Fresnel)
  mirror  -> `conductor`: physical mapping material="none" tinted by colour (an exact mirror);
             paper mapping eta/k fitted to the paper's 0.1 + 0.9 (1 - cos)^3
  light   -> sphere with an `area` emitter; with light="point" also a `point` emitter at its
             centre (light_units.py gives both values)
  background -> `constant` emitter, the only emitter of a scene without lights
  a sphere of radius >= 100 (the paper's floor) -> a spherical-cap mesh (cap_mesh.py) unless
             keep_huge_spheres
"""

from __future__ import annotations

import functools
import math
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mitsuba_ref.cap_mesh import HUGE_RADIUS, CapMesh, build_cap
from mitsuba_ref.conductor_fit import ConductorFit, fit_paper_conductor
from mitsuba_ref.light_units import light_values
from mitsuba_ref.plugin_tree import RGB, Color, LookAt, Plugin, Point, to_dict, to_xml
from mitsuba_ref.ply import write_ply
from safe_files.paths import write_atomic
from scene_model.scene import Scene, Sphere, Vec3

LIGHTS = ("area", "point")
MAPPINGS = ("physical", "paper")


@dataclass(frozen=True)
class ExportOptions:
    light: str = "area"  # area | point
    light_units: str = "calibrated"  # calibrated | physical
    mapping: str = "physical"  # physical | paper (mirror Fresnel)
    keep_huge_spheres: bool = False
    integrator: str = "path"  # the integrator written into the XML: path | rtval_whitted
    spp: int = 16
    centre_rays: bool = False
    for_path: bool = False  # point lights: drop the light's sphere, which would occlude it

    def __post_init__(self) -> None:
        if self.light not in LIGHTS:
            raise ValueError(f"light must be one of {LIGHTS}, got {self.light!r}")
        if self.mapping not in MAPPINGS:
            raise ValueError(f"mapping must be one of {MAPPINGS}, got {self.mapping!r}")
        if self.spp < 1:
            raise ValueError(f"spp must be >= 1, got {self.spp}")


@dataclass
class ExportedScene:
    tree: Plugin
    meshes: dict[str, CapMesh]  # PLY file name -> mesh
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)  # what the user should know
    light_factors: dict[str, float] = field(default_factory=dict)
    conductor: ConductorFit | None = None
    # shape id -> index into scene.spheres (for the id AOV)
    shape_index: dict[str, int] = field(default_factory=dict)

    def xml(self) -> str:
        head = '<?xml version="1.0" encoding="utf-8"?>\n'
        return head + to_xml(self.tree) + "\n"

    def write(self, path: str | Path) -> list[Path]:
        """Writes the XML and its PLY meshes beside it; returns the files written."""
        p = Path(path)
        written = []
        for name, mesh in self.meshes.items():
            _write(p.parent / name, functools.partial(write_ply, mesh=mesh))
            written.append(p.parent / name)
        # Last: an XML on disk always has its meshes beside it.
        _write(p, lambda f: write_atomic(f, self.xml()))
        return [p, *written]

    def load(self, mi: Any) -> Any:
        """The same scene loaded from a dict. The PLY meshes go to a temporary folder that is
        removed once Mitsuba has read them (load_dict reads every mesh before it returns)."""
        with tempfile.TemporaryDirectory(prefix="rtval-meshes-") as tmp:
            folder = Path(tmp)
            for name, mesh in self.meshes.items():
                write_ply(folder / name, mesh)
            d = to_dict(self.tree, mi)
            for value in d.values():
                if isinstance(value, dict) and value.get("type") == "ply":
                    value["filename"] = str(folder / value["filename"])
            return mi.load_dict(d)


def _write(path: Path, write: Callable[[Path], None]) -> None:
    """`write(path)` (atomic: a unique temporary name, never through a link, removed on any
    error); an OSError (a full disk) names the file."""
    try:
        write(path)
    except OSError as e:
        if not e.strerror:  # already a message of ours (an unsafe target), naming the file
            raise
        raise OSError(f"{path}: cannot write: {e.strerror}") from None


@functools.lru_cache(maxsize=1)
def _paper_conductor() -> ConductorFit:
    return fit_paper_conductor()


def shape_id(index: int) -> str:
    return f"sphere_{index}"


def light_id(index: int) -> str:
    return f"light_{index}"


def _reflectance(value: Vec3) -> RGB | Plugin:
    """A reflectance as Mitsuba takes it. Its RGB refuses values above 1, which the scene
    format allows and the demo renders (the surface gives back more light than it receives):
    those go in as an unbounded srgb texture, rendered as given."""
    if max(value) <= 1.0:
        return RGB(value)
    return Plugin("texture", "srgb", {"color": Color(value), "unbounded": True})


def _bsdf(s: Sphere, where: str, options: ExportOptions, exported: ExportedScene) -> Plugin:
    """Sphere `s` (at `where` in the scene file)'s material."""
    if max(s.color) > 1.0:
        exported.warnings.append(
            f"{where}.color: sphere '{s.name}' has a colour above 1 "
            f"({', '.join(f'{c:g}' for c in s.color)}): it reflects more light than it "
            "receives; Mitsuba renders it as given, as the demo does"
        )
    colour = _reflectance(s.color)
    if s.kind == "glass":
        return Plugin(
            "bsdf",
            "dielectric",
            {
                "int_ior": float(s.ior),
                "ext_ior": 1.0,
                "specular_reflectance": colour,
                "specular_transmittance": _reflectance(
                    (
                        s.color[0] * s.transparency,
                        s.color[1] * s.transparency,
                        s.color[2] * s.transparency,
                    )
                ),
            },
        )
    if s.kind == "mirror":
        if options.mapping == "paper":
            fit = _paper_conductor()
            exported.conductor = fit
            return Plugin(
                "bsdf",
                "conductor",
                {
                    "eta": RGB((fit.eta,) * 3),
                    "k": RGB((fit.k,) * 3),
                    "specular_reflectance": colour,
                },
                comment=f"paper mapping: eta {fit.eta:.4f}, k {fit.k:.4f} fitted to 0.1 + 0.9 (1 - cos)^3, "
                f"RMS error {fit.rms_error:.4f}, max {fit.max_error:.4f}",
            )
        return Plugin("bsdf", "conductor", {"material": "none", "specular_reflectance": colour})
    return Plugin("bsdf", "diffuse", {"reflectance": colour})


def export_scene(scene: Scene, options: ExportOptions = ExportOptions()) -> ExportedScene:
    root = Plugin(
        "scene",
        "scene",
        comment=(
            f"rtval export of scene '{scene.name}' ({scene.source or 'in memory'})\n"
            f"light={options.light} light_units={options.light_units} mapping={options.mapping} "
            f"keep_huge_spheres={options.keep_huge_spheres}\n"
            "materials: diffuse -> diffuse(colour); glass -> dielectric(int_ior=ior, ext_ior=1, "
            "R=colour, T=colour*transparency); mirror -> conductor; light -> area/point emitter; "
            "background -> constant emitter"
        ),
    )
    exported = ExportedScene(tree=root, meshes={})
    cam = scene.camera
    far = max([math.dist(s.center, cam.position) + s.radius for s in scene.spheres] or [1.0])
    exported.notes.append(f"far_clip {far * 1.5 + 10:.6g} (beyond every sphere)")
    root.props["integrator"] = _integrator(scene, options)
    root.props["sensor"] = _sensor(scene, options, far * 1.5 + 10.0)
    root.props["background"] = Plugin(
        "emitter",
        "constant",
        {"radiance": RGB(scene.background)},
        id="background",
        comment="the paper's background colour: what camera and specular rays that miss see",
    )
    if not scene.lights:
        # Mitsuba renders a scene whose only emitter is the environment (any integrator).
        exported.notes.append(
            "no light: the background (constant emitter) is the only emitter; in rtval_whitted "
            "diffuse surfaces stay black, the path tracer lights them from the sky"
        )
    for i, s in enumerate(scene.spheres):
        _add_sphere(exported, scene, i, s, options)
    return exported


def _integrator(scene: Scene, options: ExportOptions) -> Plugin:
    if options.integrator == "path":
        # camera vertex + specular chain + the light (Mitsuba counts vertices)
        max_depth = scene.max_depth + 2
        return Plugin(
            "integrator",
            "path",
            {"max_depth": max_depth, "rr_depth": max_depth, "hide_emitters": False},
            comment="Mitsuba's path tracer: the full light transport; Russian roulette off within max_depth",
        )
    return Plugin(
        "integrator",
        options.integrator,
        {"max_depth": scene.max_depth, "bias": scene.bias},
        comment="rtval's Whitted integrator (register it with mitsuba_ref.whitted.register())",
    )


def _sensor(scene: Scene, options: ExportOptions, far_clip: float) -> Plugin:
    cam = scene.camera
    if options.centre_rays:
        sampler = Plugin(
            "sampler",
            "stratified",
            {"sample_count": 1, "jitter": False},
            comment="one ray through each pixel centre, as the demo shoots",
        )
    else:
        sampler = Plugin("sampler", "independent", {"sample_count": options.spp})
    film = Plugin(
        "film",
        "hdrfilm",
        {
            "width": cam.width,
            "height": cam.height,
            "pixel_format": "rgb",
            "component_format": "float32",
            "rfilter": Plugin("rfilter", "box"),
        },
    )
    return Plugin(
        "sensor",
        "perspective",
        {
            "fov_axis": "y",
            "fov": float(cam.fov_y),
            "to_world": LookAt(cam.position, cam.look_at, cam.up),
            "near_clip": 1e-4,
            "far_clip": far_clip,
            "film": film,
            "sampler": sampler,
        },
        comment="vertical fov (fov_axis y), float32 RGB film, box filter, far clip beyond the scene",
    )


def _add_sphere(
    exported: ExportedScene, scene: Scene, i: int, s: Sphere, options: ExportOptions
) -> None:
    """Sphere i as a shape (or, for a huge one, a cap mesh), with its light's emitters."""
    sid = shape_id(i)
    props: dict[str, Any] = {}
    if s.kind == "light":
        emitter = _light(exported, scene, i, s, options)
        if emitter is None:
            return
        props["emitter"] = emitter
    props["bsdf"] = _bsdf(s, f"spheres[{i}]", options, exported)
    mesh = _cap(exported, scene, s, options)
    if mesh is not None:
        ply = f"{scene.name}_{sid}_cap.ply"
        exported.meshes[ply] = mesh
        exported.notes.append(
            f"sphere '{s.name}' (radius {s.radius:g}) exported as a spherical cap of "
            f"{len(mesh.faces)} triangles, {math.degrees(mesh.theta_max):.2f} degrees"
        )
        exported.tree.props[sid] = Plugin(
            "shape",
            "ply",
            {"filename": ply, **props},
            id=sid,
            comment=(
                f"'{s.name}': huge sphere as a graded spherical-cap mesh (float32-safe, horizon kept)"
            ),
        )
    else:
        props = {"center": Point(s.center), "radius": float(s.radius), **props}
        exported.tree.props[sid] = Plugin(
            "shape", "sphere", props, id=sid, comment=f"'{s.name}': {s.kind}"
        )
    exported.shape_index[sid] = i


def _light(
    exported: ExportedScene, scene: Scene, i: int, s: Sphere, options: ExportOptions
) -> Plugin | None:
    """The light sphere's area emitter, after its point emitter with light="point"; None when
    the sphere itself is dropped (point lights in a path render)."""
    lv = light_values(scene, s, options.light_units)
    exported.light_factors[s.name] = lv.factor
    if options.light == "point":
        exported.tree.props[light_id(i)] = Plugin(
            "emitter",
            "point",
            {"position": Point(s.center), "intensity": RGB(lv.intensity)},
            id=light_id(i),
            comment=f"light '{s.name}': point intensity = emission x {lv.factor:.6g} "
            f"({options.light_units} units)",
        )
        if options.for_path:
            exported.notes.append(
                f"light '{s.name}': sphere dropped (it would occlude its point light)"
            )
            return None
    return Plugin(
        "emitter",
        "area",
        {"radiance": RGB(lv.radiance)},
        comment=f"radiance = point intensity / (pi R^2), factor {lv.factor:.6g}",
    )


def _cap(
    exported: ExportedScene, scene: Scene, s: Sphere, options: ExportOptions
) -> CapMesh | None:
    """The cap mesh standing in for a huge sphere; None to keep it a sphere."""
    if s.radius < HUGE_RADIUS or options.keep_huge_spheres:
        return None
    try:
        return build_cap(s.center, s.radius, scene.camera.position)
    except ValueError as e:
        exported.notes.append(f"sphere '{s.name}' kept as a sphere: {e}")
        return None
