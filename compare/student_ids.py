"""Student ids made safe as file names on disk.

An id is whatever a file name said: any text, any length. On disk (results/<slug>.json,
students/<slug>/) it becomes a slug: the id itself when it is short, plain lower-case
ASCII (letters, digits, '_', '-'), otherwise a sanitised prefix, a '.' and a hash of the id,
so that two ids never share a slug (a plain id has no '.'; case-insensitive file systems
included) and no slug is a path, a hidden name or too long. The real id travels beside the slug in every result.
"""

from __future__ import annotations

import hashlib
import os
import re
import unicodedata

_PLAIN = re.compile(r"[a-z0-9_][a-z0-9_-]{0,63}")
_UNSAFE = re.compile(r"[^a-z0-9_-]+")


def student_slug(student: str) -> str:
    """A file-name-safe, unique slug for ``student`` (at most 64 + 11 ASCII characters)."""
    if _PLAIN.fullmatch(student):
        return student
    digest = hashlib.sha256(student.encode("utf-8", "surrogatepass")).hexdigest()[:10]
    stem = _UNSAFE.sub("_", student.lower()).strip("_-")[:64]
    # '.' is never in a plain id: a student naming a file after a classmate's slug
    # ("victim_name.1a2b3c4d5e") gets a slug of their own, not the classmate's.
    return f"{stem}.{digest}" if stem else f"id.{digest}"


def _hidden_or_active(c: str) -> bool:
    """A character a terminal, a spreadsheet or a browser acts on or hides: controls (ESC
    sequences), line separators and format characters such as the bidi overrides (U+202E
    shows "eve", U+202E, "gnp.exe" as "eveexe.png") and the zero-width space (U+200B in
    "mallory" hides). A TAB only moves the text on, and the zero-width (non-)joiners stay:
    some scripts spell names with them."""
    category = unicodedata.category(c)
    if c in "\t\u200c\u200d":
        return False
    return category in ("Cc", "Cf", "Zl", "Zp")


def _escaped(c: str) -> str:
    code = ord(c)
    if 0xDC80 <= code <= 0xDCFF:  # a byte of a name that was not UTF-8 (surrogateescape)
        return f"\\x{code - 0xDC00:02x}"
    return c.encode("unicode_escape").decode("ascii")


def displayable(text: str, *, lines: bool = False) -> str:
    """Text a student controls (an id, a file name, a link's target, a log line, a compiler's
    first error) made safe for a CSV cell, JSON, HTML or a terminal: every control, format,
    separator or surrogate character is written as its escape (ESC as \\x1b, U+202E as
    \\u202e, a newline as \\n), so that it cannot move the cursor, colour the terminal,
    reorder a line or start a forged one (a tab only moves the text on, and stays).
    lines=True keeps newlines (a log shown as lines); a carriage return is escaped even
    then, since it rewrites the line it ends."""
    keep = "\n" if lines else ""
    if text.isprintable():  # the common case, at C speed
        return text
    return "".join(c if c in keep or not _acts(c) else _escaped(c) for c in text)


def _acts(c: str) -> bool:
    return _hidden_or_active(c) or unicodedata.category(c) == "Cs"


def displayable_name(name: str) -> tuple[str, str | None]:
    """(text, problem) for a name from os.listdir. A name that is not UTF-8 (it arrives with
    surrogate escapes) or holds characters that act or hide is shown with them escaped, and
    the problem says why it must be renamed; a plain name is itself, with no problem."""
    try:
        name.encode("utf-8")
    except UnicodeEncodeError:
        return os.fsencode(name).decode("utf-8", "backslashreplace"), "is not UTF-8"
    if not any(_hidden_or_active(c) for c in name):
        return name, None
    shown = "".join(
        c.encode("unicode_escape").decode("ascii") if _hidden_or_active(c) else c for c in name
    )
    return shown, "holds control or invisible characters"
