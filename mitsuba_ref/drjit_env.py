"""Importing Mitsuba here: drjit's LLVM backend needs libLLVM >= 15, and Debian's default
is 14, so the project points drjit at Debian's libllvm19 before the first import."""

from __future__ import annotations

import os
from pathlib import Path
from types import ModuleType

LIBLLVM = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"
VARIANTS = ("llvm_ad_rgb", "scalar_rgb")


class MitsubaUnavailable(RuntimeError):
    """Mitsuba or the requested variant cannot be used on this machine."""


def load_mitsuba(variant: str) -> ModuleType:
    """Imports mitsuba with `variant` set; raises MitsubaUnavailable with the reason."""
    if variant not in VARIANTS:
        raise MitsubaUnavailable(
            f"unknown variant {variant!r} (expected one of {', '.join(VARIANTS)})"
        )
    if variant.startswith("llvm") and "DRJIT_LIBLLVM_PATH" not in os.environ:
        if not Path(LIBLLVM).is_file():
            raise MitsubaUnavailable(
                f"{variant} needs libLLVM >= 15: {LIBLLVM} is missing (apt-get install libllvm19, "
                "or run `make setup`), or use --variant scalar_rgb"
            )
        os.environ["DRJIT_LIBLLVM_PATH"] = LIBLLVM
    try:
        import mitsuba as mi
    except ImportError as e:
        raise MitsubaUnavailable(f"cannot import mitsuba: {e}") from None
    try:
        mi.set_variant(variant)
    except Exception as e:  # drjit raises plain exceptions when the backend fails
        raise MitsubaUnavailable(f"cannot use Mitsuba variant {variant}: {e}") from None
    return mi
