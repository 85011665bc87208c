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


def displayable_name(name: str) -> tuple[str, bool]:
    """(text, is_utf8) for a name from os.listdir: a name that is not UTF-8 arrives with
    surrogate escapes, which cannot be written as UTF-8; show its bytes escaped instead."""
    try:
        name.encode("utf-8")
        return name, True
    except UnicodeEncodeError:
        return os.fsencode(name).decode("utf-8", "backslashreplace"), False
