"""What a file holds, from its first bytes: the words an error message gives a person whose
image is not what its name says (a PPM saved as out.exr, random bytes saved as x.png)."""

from __future__ import annotations

from dataclasses import dataclass

HEAD_BYTES = 16  # the longest signature below, with room to spare


@dataclass(frozen=True)
class Kind:
    """A kind of file. `key` is the suffix rtval reads it under ("" for one it cannot read);
    `words` names it in a sentence ("a PPM (P6)")."""

    key: str
    words: str


_SIGNATURES: tuple[tuple[bytes, Kind], ...] = (
    (b"\x76\x2f\x31\x01", Kind("exr", "an OpenEXR image")),
    (b"\x89PNG\r\n\x1a\n", Kind("png", "a PNG")),
    (b"\xff\xd8\xff", Kind("", "a JPEG")),
    (b"GIF8", Kind("", "a GIF")),
    (b"II*\x00", Kind("", "a TIFF")),
    (b"MM\x00*", Kind("", "a TIFF")),
    (b"#?RADIANCE", Kind("", "a Radiance HDR")),
    (b"#?RGBE", Kind("", "a Radiance HDR")),
    (b"%PDF", Kind("", "a PDF")),
    (b"PK\x03\x04", Kind("", "a ZIP archive")),
    (b"\x1f\x8b", Kind("", "a gzip archive")),
    (b"\x7fELF", Kind("", "a program (ELF)")),
)
# Netpbm and PFM: two letters and whitespace. Every Netpbm kind is read under .ppm/.pnm (the
# decoder refuses the 1-bit ones, saying so); each is named, so a mistake says what was written.
_NETPBM = {
    b"P1": Kind("ppm", "a text PBM (P1)"),
    b"P2": Kind("ppm", "a text PGM (P2)"),
    b"P3": Kind("ppm", "a text PPM (P3)"),
    b"P4": Kind("ppm", "a binary PBM (P4)"),
    b"P5": Kind("ppm", "a PGM (P5)"),
    b"P6": Kind("ppm", "a PPM (P6)"),
    b"PF": Kind("pfm", "a PFM (PF)"),
    b"Pf": Kind("pfm", "a grey PFM (Pf)"),
}
# The kind each suffix rtval reads promises, in words.
EXPECTED = {
    "exr": "an OpenEXR image",
    "png": "a PNG",
    "ppm": "a PPM",
    "pnm": "a PPM",
    "pfm": "a PFM",
}


def identify(head: bytes) -> Kind | None:
    """The kind the first bytes announce; None when they match no signature above."""
    for signature, kind in _SIGNATURES:
        if head.startswith(signature):
            return kind
    if len(head) >= 3 and head[:2] in _NETPBM and head[2:3].isspace():
        return _NETPBM[head[:2]]
    return None


def describe(head: bytes) -> str:
    """What the first bytes are, as the end of "the file holds ...": a known format, text
    (quoted, shortened), nothing, or binary data matching no image format."""
    kind = identify(head)
    if kind is not None:
        return kind.words
    if not head:
        return "nothing (it is empty)"
    text = _utf8_text(head)
    if text is None:
        return "binary data that begins like no image format"
    words = " ".join(text.split())
    shown = words if len(words) <= 12 else words[:12] + "…"
    return f'text ("{shown}")'


def _utf8_text(head: bytes) -> str | None:
    """`head` as text when it is printable UTF-8 (a character cut at its end allowed)."""
    for cut in range(4):
        try:
            text = head[: len(head) - cut].decode("utf-8")
        except UnicodeDecodeError:
            continue
        return text if all(c.isprintable() or c in " \t\r\n" for c in text) else None
    return None


def same_family(suffix_key: str, kind: Kind) -> bool:
    """Whether a file of `kind` is what a name with this suffix promises (.pnm and .ppm hold
    the same Netpbm kinds)."""
    family = "ppm" if suffix_key == "pnm" else suffix_key
    return kind.key == family


def output_problem(data: bytes, name: str) -> str:
    """Why a program's output is not the image its name's suffix promises ("" when it is),
    judged before any decoder sees it (none is ever chosen by the bytes: an EPS would reach
    Ghostscript)."""
    key = name.rsplit(".", 1)[-1].lower()
    if key not in EXPECTED:
        return f"output is not an image: {name} has no known image suffix"
    head = data[:HEAD_BYTES]
    kind = identify(head)
    if kind is not None and same_family(key, kind):
        return ""
    return f"output is not {EXPECTED[key]}: {name} holds {describe(head)}"
