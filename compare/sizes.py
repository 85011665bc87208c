"""Sizes in binary units, as the sandbox's limits and the rubric give them."""

from __future__ import annotations

import re


def parse_size(text: str | int) -> int:
    """Bytes from 2G, 512M, 64K, 2GiB, 1.5G or a plain number of bytes (binary units)."""
    if isinstance(text, int) and not isinstance(text, bool):
        if text <= 0:
            raise ValueError(f"a size must be positive, got {text}")
        return text
    m = re.fullmatch(r"\s*([0-9]+(?:\.[0-9]+)?)\s*([KMGT]?)(?:i?B)?\s*", str(text), re.IGNORECASE)
    if not m:
        raise ValueError(f"expected a size such as 2G, 512M or 64K, got {text!r}")
    unit = m.group(2).upper()
    value = float(m.group(1)) * (1024 ** ("KMGT".index(unit) + 1) if unit else 1)
    if not 1 <= value < 2**62:
        raise ValueError(f"a size must be from 1 byte to 4 EiB, got {text!r}")
    return int(value)


def human_size(n: int) -> str:
    """2 GiB, 256 MiB, 64 KiB, 100 B: the units the limits are given in."""
    for unit, scale in (("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= scale:
            v = n / scale
            return f"{v:.0f} {unit}" if v == int(v) or v >= 100 else f"{v:.1f} {unit}"
    return f"{n} B"
