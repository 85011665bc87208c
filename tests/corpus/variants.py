"""The corpus's variants: every program of tests/corpus built the ways real students and
maintainers build it, and the mistake variants of the scratchapixel-style program.

Correct variants must pass against their model with score 100; each mistake variant must
fail, and `rtval diagnose` must name what it does wrong (tests/test_corpus.py pins both).
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


MISTAKE_BUILDS: dict[str, tuple[str, str]] = {
    # variant -> (define, what the program does wrong)
    "depth10": ("MAX_RAY_DEPTH=10", "recursion limit 10 instead of the scene's 5"),
    "depth3": ("MAX_RAY_DEPTH=3", "recursion limit 3 instead of the scene's 5"),
    "eta_inverted": ("ETA_INVERTED", "the index ratio the wrong way up at both crossings"),
    "fresnel_exponent": ("FRESNEL_SQUARE", "Fresnel 0.1 + 0.9 (1 - cos)^2"),
    "black_background": ("BLACK_BACKGROUND", "a miss returns black"),
    "no_inside_flip": ("NO_INSIDE_FLIP", "the normal is not turned round inside glass"),
    "no_offset": ("NO_BIAS", "secondary and shadow rays start on the surface"),
    "half_pixel_offset": ("PIXEL_CORNERS", "camera rays through pixel corners"),
    "untinted_glass": ("UNTINTED_GLASS", "the glass is never multiplied by its colour"),
    "ior1.5": ("GLASS_IOR=1.5", "glass index 1.5 instead of the scene's 1.1"),
}


def _mistakes() -> list[Variant]:
    return [
        Variant(f"scratch-{name}", Build(SCRATCH, "g++", ("-O2",), (define,)), mistake=what)
        for name, (define, what) in MISTAKE_BUILDS.items()
    ]


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
            "paper-mirrored",
            b,
            "paper",
            "paper",
            PAPER_SMALL,
            ("paper", *args, "--mirror"),
            mistake="the picture mirrored left to right, as the paper's OpenGL window shows it",
        ),
    ]


CORRECT = _correct()
MISTAKES = _mistakes()
PAPER_VARIANTS = _paper()
ALL = CORRECT + MISTAKES + PAPER_VARIANTS
BY_NAME = {v.name: v for v in ALL}
