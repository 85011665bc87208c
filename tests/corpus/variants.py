"""The corpus's variants: every program of tests/corpus built the ways real students and
maintainers build it, and the mistake variants: the scratchapixel-style C++ program's
(compile-time defines) and the Rust, Go and JavaScript programs' (run-time switches,
`--mistake NAME[,NAME]`, so each is built once).

Correct variants must pass against their model with score 100; each mistake variant must
fail, and `rtval diagnose` must name one of its true causes or, naming none, localise it to
the step where it lives, and never name any other cause (tests/test_corpus.py pins these).
"""

from __future__ import annotations

from corpus.programs import Build, Variant

FULL = (640, 480)  # classic.json's own size
SMALL = (320, 240)
PAPER_SMALL = (360, 240)  # paper.json is 1200x800 (3:2)
PAPER_FULL = (1200, 800)

SCRATCH = "scratch_float.cpp"
C99 = "classic_c99.c"
DOUBLE = "classic_double.cpp"
PAPER = "paper_student.cpp"

# name -> (tool, flags, needs FMA): the ways a C or C++ program is commonly built.
_CXX_BUILDS = {
    "gcc-O0": ("g++", ("-O0",), False),
    "gcc-O2": ("g++", ("-O2",), False),
    "gcc-O3": ("g++", ("-O3",), False),
    "clang-O2": ("clang++", ("-O2",), False),
    "gcc-O2-fma": ("g++", ("-O2", "-mfma", "-ffp-contract=fast"), True),
    "gcc-O2-fastmath": ("g++", ("-O2", "-ffast-math"), False),
}
_C_TOOLS = {"g++": "gcc", "clang++": "clang"}


def _builds(source: str, c: bool = False) -> dict[str, Build]:
    out = {}
    for name, (tool, flags, fma) in _CXX_BUILDS.items():
        out[name] = Build(source, _C_TOOLS[tool] if c else tool, flags, needs_fma=fma)
    return out


def _correct() -> list[Variant]:
    out: list[Variant] = []
    for prefix, source, c, full in (
        ("scratch", SCRATCH, False, ("gcc-O2", "gcc-O3")),
        ("c99", C99, True, ()),
        ("double", DOUBLE, False, ("gcc-O2",)),
    ):
        for name, build in _builds(source, c).items():
            size = FULL if name in full else SMALL
            out.append(Variant(f"{prefix}-{name}", build, size=size))
    # Two more ways people build the float program: clang's own FMA contraction (on by
    # default within an expression) and GCC's "as fast as this machine goes".
    out.append(
        Variant("scratch-clang-O2-fma", Build(SCRATCH, "clang++", ("-O2", "-mfma"), needs_fma=True))
    )
    out.append(
        Variant(
            "scratch-gcc-O3-native", Build(SCRATCH, "g++", ("-O3", "-march=native"), needs_fma=True)
        )
    )
    out.append(Variant("rust-O", Build("classic.rs", "rustc", ("-O",))))
    out.append(Variant("go", Build("classic.go", "go")))
    # GOAMD64=v3 lets the Go compiler fuse x*y+z into FMA instructions (the Go spec allows it).
    out.append(
        Variant("go-amd64v3", Build("classic.go", "go", env=(("GOAMD64", "v3"),), needs_fma=True))
    )
    out.append(Variant("js-node", Build("classic.js", "node")))
    return out


# The steps of the algorithm (the diagnosis' vocabulary, docs/diagnosis.md).
CAMERA, WRITING, INTERSECTION, NORMAL = "camera", "image writing", "intersection", "normal"
REFLECTION, ENTERING, LEAVING = "reflection", "refraction entering", "refraction leaving"
FRESNEL, SHADOW, DIRECT = "fresnel", "shadow rays", "direct light"
DEPTH, CONSTANT, BACKGROUND = "depth limit", "constant", "background"
GLASS = frozenset({ENTERING, LEAVING})

# Cause names as the diagnosis JSON writes them (compare/diagnose/record.py, switches.py,
# transforms.py): the writer's transforms, the switches, the named mistakes.
BGR = "channels written as B, G, R (not R, G, B)"
UPSIDE_DOWN = "mirrored upside down"
WRAP = "values over 1 not clamped: they wrap round to dark codes"
NO_SHADOWS = frozenset({"--no-shadows", "no_shadows"})
# Causes the classic scene cannot tell apart (measured: the images are identical): the ground,
# the first sphere tested, never shadows a point of its own top, so a loop that stops after it
# blocks nothing; and with the light direction reversed every lit face gets no light, as when
# the light sphere blocks every shadow ray, or when an unnormalised shadow direction makes the
# unit-direction sphere test see a blocker in every sphere ahead (the Go program's image is
# rtdemo's light_dir_reversed render within one level at every pixel).
FIRST_ONLY = NO_SHADOWS | {"shadow_first_only"}
# refraction_unweighted's image is glass of transparency 1: the diagnosis names that symptom.
UNWEIGHTED = "glass passes all its light (transparency 1, or not applied)"
# The diagnosis names their shared symptom (mistakes.json "symptom"), not one of them.
DARK_DIRECT = frozenset(
    {
        "direct light lost",
        "light_dir_reversed",
        "light_blocks_itself",
        "light_colour_from_hit",
        "shadow_dir_unnormalized",
    }
)
# A normal turned inward makes the Fresnel weight 1 at every outside hit, so whether the inside
# flag is right or not no refracted ray counts: the images are identical.
INWARD = frozenset({"flipped_normal", "inside_test_reversed"})


def depths(d: int) -> frozenset[str]:
    """A recursion limit d as the diagnosis may name it: exactly, or as "N or more" for an
    N <= d that every deeper limit renders alike (the scene asks 5)."""
    return frozenset({f"max depth {d}"} | {f"max depth {n} or more" for n in range(6, d + 1)})


def _c(*names: str | frozenset[str]) -> frozenset[str]:
    out: set[str] = set()
    for n in names:
        out |= {n} if isinstance(n, str) else n
    return frozenset(out)


# variant -> (define, what the program does wrong, true causes, steps)
MISTAKE_BUILDS: dict[str, tuple[str, str, frozenset[str], frozenset[str]]] = {
    "depth10": ("MAX_RAY_DEPTH=10", "recursion limit 10 instead of the scene's 5", depths(10),
                _c(DEPTH, CONSTANT)),
    "depth3": ("MAX_RAY_DEPTH=3", "recursion limit 3 instead of the scene's 5", depths(3),
               _c(DEPTH, CONSTANT)),
    "eta_inverted": ("ETA_INVERTED", "the index ratio the wrong way up at both crossings",
                     _c("eta_inverted"), GLASS),
    "fresnel_exponent": ("FRESNEL_SQUARE", "Fresnel 0.1 + 0.9 (1 - cos)^2",
                         _c("fresnel_exponent"), _c(FRESNEL)),
    "black_background": ("BLACK_BACKGROUND", "a miss returns black", _c("black_background"),
                         _c(BACKGROUND, CONSTANT)),
    "no_inside_flip": ("NO_INSIDE_FLIP", "the normal is not turned round inside glass",
                       _c("no_inside_flip"), _c(LEAVING)),
    "no_offset": ("NO_BIAS", "secondary and shadow rays start on the surface",
                  _c("no_offset"), _c(REFLECTION, SHADOW, CONSTANT)),
    "half_pixel_offset": ("PIXEL_CORNERS", "camera rays through pixel corners",
                          _c("half_pixel_offset"), _c(CAMERA)),
    # No switch renders it: the steps only.
    "untinted_glass": ("UNTINTED_GLASS", "the glass is never multiplied by its colour",
                       frozenset(), _c(GLASS, REFLECTION)),
    "ior1.5": ("GLASS_IOR=1.5", "glass index 1.5 instead of the scene's 1.1", _c("ior 1.5"),
               _c(GLASS, CONSTANT)),
}  # fmt: skip


def _mistakes() -> list[Variant]:
    return [
        Variant(
            f"scratch-{name}",
            Build(SCRATCH, "g++", ("-O2",), (define,)),
            mistake=what,
            causes=causes,
            steps=steps,
        )
        for name, (define, what, causes, steps) in MISTAKE_BUILDS.items()
    ]


RUST, GO, JS = (
    Build("classic.rs", "rustc", ("-O",)),
    Build("classic.go", "go"),
    Build("classic.js", "node"),
)

# variant -> (program, its --mistake list, what it does wrong, true causes, steps): the
# programs' run-time switches (each program's header lists them).
SWITCHED: dict[str, tuple[Build, str, str, frozenset[str], frozenset[str]]] = {
    # image writing
    "go-rows_bottom_up": (GO, "rows_bottom_up", "the writer starts at the bottom row",
                          _c(UPSIDE_DOWN), _c(WRITING)),
    "js-bgr": (JS, "bgr", "the writer puts blue first", _c(BGR), _c(WRITING)),
    "go-no_clamp": (GO, "no_clamp", "byte(int(v * 255)) without a clamp", _c(WRAP),
                    _c(WRITING)),
    "js-gamma2": (JS, "gamma2", "sqrt(v) written: a gamma-2 encoding",
                  _c("every value raised to the power 1/2"), _c(WRITING)),
    "rust-exposure08": (RUST, "exposure08", "every value multiplied by 0.8 before writing",
                        _c("every value multiplied by 0.8"), _c(WRITING)),
    # camera (those without a named mistake: fitted from the silhouettes, camera_fit.py)
    "rust-fov35": (RUST, "fov35", "a 35 degree field of view",
                   _c("camera: a field of view of 35 degrees (the scene's is 30)"), _c(CAMERA)),
    "go-fov_on_x": (GO, "fov_on_x", "the field of view taken as horizontal",
                    _c("camera: the field of view (30 degrees) taken as the horizontal one"),
                    _c(CAMERA)),
    "js-tan_full_fov": (JS, "tan_full_fov", "tan(fov) instead of tan(fov / 2)",
                        _c("fov_full_angle"), _c(CAMERA)),
    "rust-no_aspect": (RUST, "no_aspect", "x not scaled by the aspect ratio",
                       _c("aspect_ratio_missing"), _c(CAMERA)),
    "go-pixel_corners": (GO, "pixel_corners", "camera rays through pixel corners",
                         _c("half_pixel_offset"), _c(CAMERA)),
    # intersection
    "go-near_root_only": (GO, "near_root_only", "a sphere whose near root is behind is missed",
                          _c("near_root_only"), _c(INTERSECTION, LEAVING)),
    "rust-negative_root_hit": (RUST, "negative_root_hit", "a root behind the ray is hit",
                               _c("negative_root_hit"), _c(INTERSECTION, LEAVING)),
    "js-ray_dir_unnormalized": (JS, "ray_dir_unnormalized", "camera rays not normalised",
                                _c("ray_dir_unnormalized"), _c(CAMERA, INTERSECTION)),
    # normal
    "go-normal_not_normalized": (GO, "normal_not_normalized", "the normal p - c as it is",
                                 _c("normal_not_normalized"), _c(NORMAL)),
    "js-inside_test_reversed": (JS, "inside_test_reversed", "the inside test d.n < 0",
                                INWARD, _c(NORMAL)),
    "rust-flipped_normal": (RUST, "flipped_normal", "the facing test's branches swapped",
                            INWARD, _c(NORMAL)),
    # reflection
    "js-reflect_sign": (JS, "reflect_sign", "d + 2 (d.n) n", _c("reflect_sign"),
                        _c(REFLECTION)),
    "go-reflection_untinted": (GO, "reflection_untinted", "the reflection not tinted",
                               _c("reflection_untinted"), _c(REFLECTION)),
    # refraction
    "rust-eta_inverted": (RUST, "eta_inverted", "the index ratio the wrong way up",
                          _c("eta_inverted"), GLASS),
    "go-eta_leaving": (GO, "eta_leaving", "1/ior when leaving glass too", _c("+Q2"),
                       _c(LEAVING)),
    "js-no_inside_flip": (JS, "no_inside_flip", "the normal not turned round inside",
                          _c("no_inside_flip"), _c(LEAVING)),
    "rust-refraction_bias_outside": (RUST, "refraction_bias_outside",
                                     "the refracted ray starts outside the surface",
                                     _c("refraction_bias_outside"), GLASS),
    "js-refraction_unweighted": (JS, "refraction_unweighted",
                                 "the refraction not weighted by the transparency",
                                 _c("refraction_unweighted", UNWEIGHTED), GLASS),
    # Fresnel
    "go-fresnel_facing_sign": (GO, "fresnel_facing_sign", "the facing ratio +d.n",
                               _c("fresnel_facing_sign"), _c(FRESNEL)),
    # facing = 0 on every hit: the paper's curve gives 1, as the curve fitted with mix 1
    "go-fresnel_facing_clamped": (GO, "fresnel_facing_clamped", "the facing ratio max(0, +d.n)",
                                  _c("Fresnel 1 at every angle"), _c(FRESNEL)),
    "js-fresnel_weights_swapped": (JS, "fresnel_weights_swapped", "the weights swapped",
                                   _c("fresnel_weights_swapped"), _c(FRESNEL)),
    "rust-fresnel_exponent": (RUST, "fresnel_exponent", "(1 - facing)^2",
                              _c("fresnel_exponent"), _c(FRESNEL)),
    # shadow rays
    "js-light_blocks_itself": (JS, "light_blocks_itself", "the light blocks its shadow rays",
                               DARK_DIRECT, _c(SHADOW, DIRECT)),
    "rust-shadow_first_only": (RUST, "shadow_first_only", "the occluder loop stops at once",
                               FIRST_ONLY, _c(SHADOW)),
    "go-shadow_dir_unnormalized": (GO, "shadow_dir_unnormalized",
                                   "the shadow ray's direction not normalised",
                                   DARK_DIRECT, _c(SHADOW)),
    "js-no_shadows": (JS, "no_shadows", "no shadow test", FIRST_ONLY, _c(SHADOW)),
    # direct light
    "rust-light_dir_reversed": (RUST, "light_dir_reversed", "the light direction p - light",
                                DARK_DIRECT, _c(DIRECT)),
    # In no catalogue (mistake_changes.md: with one light rtdemo's image is the clamped one);
    # here the negative light is carried through the glass's mix, a level or so.
    "go-lambert_unclamped": (GO, "lambert_unclamped", "n.l without max(0, .)", frozenset(),
                             _c(DIRECT)),
    # constants
    "js-ior1.5": (JS, "ior=1.5", "glass index 1.5", _c("ior 1.5"), _c(GLASS, CONSTANT)),
    "go-bias1e-3": (GO, "bias=0.001", "an offset of 1e-3", _c("bias 0.001"),
                    _c(CONSTANT, REFLECTION, SHADOW)),
    "rust-depth3": (RUST, "depth=3", "recursion limit 3", depths(3), _c(DEPTH, CONSTANT)),
    "rust-white_background": (RUST, "background=1", "a white background (1, 1, 1)",
                              _c("background (1, 1, 1)"), _c(BACKGROUND, CONSTANT)),
    # a Python port's slip: eta = 1 if inside else 1 / ior
    "go-eta_one_leaving": (GO, "eta_one_leaving", "eta 1 when leaving glass",
                           _c("eta_one_leaving"), _c(LEAVING)),
    # a real program's slip (serifagir/ray-tracing-engine-cli): light - n for light - p
    "js-light_dir_from_normal": (JS, "light_dir_from_normal", "the light direction from the normal",
                                 _c("light_dir_from_normal"), _c(DIRECT)),
    # two changes at once
    # ggerholm's Java port: the light's colour read off the shaded sphere, and its glass blue
    "js-light_blocks_itself-glass_blue0.26": (JS, "light_blocks_itself,glass_blue=0.26",
                                              "lit surfaces black and the glass (1, 0.32, 0.26)",
                                              DARK_DIRECT | _c("colour of 'glass' (1, 0.32, 0.26)"),
                                              _c(DIRECT, GLASS)),
    "go-depth10-bias1e-3": (GO, "depth=10,bias=0.001", "depth 10 and an offset of 1e-3",
                            _c(depths(10), "bias 0.001"), _c(DEPTH, CONSTANT)),
    # three, as CAPBenchmarks' RT kernel has them (its light at y 30, scratchapixel's at 20)
    "go-cap-light_y30-depth10-bias1e-3": (GO, "light_y=30,depth=10,bias=0.001",
                                          "the light at y 30, depth 10 and an offset of 1e-3",
                                          _c(depths(10), "bias 0.001", "light at (0, 30, -30)"),
                                          _c(DEPTH, CONSTANT, DIRECT)),
    "js-ior1.5-fresnel_exponent": (JS, "ior=1.5,fresnel_exponent", "ior 1.5 and (1 - cos)^2",
                                   _c("ior 1.5", "fresnel_exponent"), _c(GLASS, FRESNEL)),
    "rust-bgr-black_background": (RUST, "bgr,black_background", "BGR and a black background",
                                  _c(BGR, "black_background"), _c(WRITING, BACKGROUND)),
    "js-bgr-no_shadows": (JS, "bgr,no_shadows", "BGR and no shadow test",
                          _c(BGR, FIRST_ONLY), _c(WRITING, SHADOW)),
    "go-rows_bottom_up-depth3": (GO, "rows_bottom_up,depth=3", "bottom row first, depth 3",
                                 _c(UPSIDE_DOWN, depths(3)), _c(WRITING, DEPTH)),
    # in no catalogue: the curve's constants are fitted as values
    "rust-fresnel_constants_swapped": (RUST, "fresnel_constants_swapped",
                                       "0.9 + 0.1 (1 - cos)^3",
                                       _c("Fresnel 0.9 + 0.1 (1 - cos)^3"), _c(FRESNEL)),
    # in no catalogue: the camera fitted from the silhouettes
    "go-y_by_width": (GO, "y_by_width", "the row divided by the width",
                      _c("camera: the row divided by the width, not the height"), _c(CAMERA)),
    # in no catalogue: a typo no switch reproduces, so only its step can be told
    "js-reflect_half": (JS, "reflect_half", "d - (d.n) n: the 2 forgotten", frozenset(),
                        _c(REFLECTION)),
    "js-k_eta_unsquared": (JS, "k_eta_unsquared", "1 - eta (1 - cos^2) under the root",
                           frozenset(), GLASS),
    # A red-team pass's programs (docs/diagnosis.md "Measured"): before the gate `followed`,
    # each got a false cause (--no-shadows, eta_inverted with +Q2, direct light lost, ior 1.3
    # and +Q2 in turn); the first two are named mistakes now, the others only localised.
    "go-glass_no_shadow": (GO, "glass_no_shadow", "the shadow loop skips glass",
                           _c("shadow_skips_glass"), _c(SHADOW, "shadow through glass")),
    "go-eta_ior_both": (GO, "eta_ior_both", "eta = ior at both crossings", _c("eta_ior_both"),
                        GLASS),
    "js-cosi_sign": (JS, "cosi_sign", "cos i taken as +n.d", _c("cosi_sign"), GLASS),
    "go-normal_precedence": (GO, "normal_precedence", "the normal p - c/r", frozenset(),
                             _c(NORMAL)),
    "js-watt_refraction": (JS, "watt_refraction", "the root over eta^2 in the direction",
                           frozenset(), GLASS),
    "go-cosi_unflipped": (GO, "cosi_unflipped", "cos i from the normal before the flip",
                          frozenset(), GLASS),
    # The second pass's: told "direct light lost" and reflect_sign before far_root existed.
    "go-far_root": (GO, "far_root", "the far root tca + thc", _c("far_root"), _c(INTERSECTION)),
    # Capped at 1, the sky mixes in as a background of 1 would: the diagnosis says both, the
    # cap as the alternative (switches.py), since only the light seen in glass tells them apart.
    "js-clamp_each_trace": (JS, "clamp_each_trace", "every traced colour capped at 1",
                            _c("background (1, 1, 1)"), _c(BACKGROUND, "emission")),
}  # fmt: skip


def _switched() -> list[Variant]:
    out = []
    for name, (build, switch, what, causes, steps) in SWITCHED.items():
        argv = ("{w}", "{h}", "{out}", "--mistake", switch)
        out.append(Variant(name, build, argv=argv, mistake=what, causes=causes, steps=steps))
    return out


def _paper() -> list[Variant]:
    b = Build(PAPER, "g++", ("-O2",))
    args = ("{w}", "{h}", "{out}")
    return [
        Variant("paper-gcc-O2", b, "paper", "paper", PAPER_SMALL, ("paper", *args)),
        Variant(
            "paper-clang-O2",
            Build(PAPER, "clang++", ("-O2",)),
            "paper",
            "paper",
            PAPER_SMALL,
            ("paper", *args),
        ),
        # At the paper's own size its depth-10 glass chains are where float chaos is widest.
        Variant(
            "paper-c-style-full",
            Build(PAPER, "g++", ("-O2",), ("C_STYLE",)),
            "paper",
            "paper",
            PAPER_FULL,
            ("paper", *args),
        ),
        Variant("paper-lit-gcc-O2", b, "lit", "paper", SMALL, ("lit", *args)),
        Variant(
            "paper-lit-look_at_as_direction",
            b,
            "lit",
            "paper",
            SMALL,
            ("lit", *args, "--look-at-as-direction"),
            mistake="the camera looks along lookAt itself, the eye not subtracted",
            causes=frozenset(
                {"camera: look_at taken as a direction from the position, not a point"}
            ),
            steps=frozenset({CAMERA}),
        ),
        Variant(
            "paper-mirrored",
            b,
            "paper",
            "paper",
            PAPER_SMALL,
            ("paper", *args, "--mirror"),
            mistake="the picture mirrored left to right, as the paper's OpenGL window shows it",
            causes=frozenset({"mirrored left-right"}),
            steps=frozenset({WRITING}),
        ),
    ]


CORRECT = _correct()
MISTAKES = _mistakes() + _switched()
PAPER_VARIANTS = _paper()
ALL = CORRECT + MISTAKES + PAPER_VARIANTS
BY_NAME = {v.name: v for v in ALL}
