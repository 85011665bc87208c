"""The entries of a submissions folder, each turned into one student row.

A submission is a regular file inside the folder (or a folder of regular files, one per
scene). Nothing is followed outside: a symbolic link (dangling or not, to the reference, to
/etc or to /dev/zero), a FIFO, a socket or a device becomes a row with a reason, as does a
name that is not UTF-8 or two entries for one id (alice.ppm and alice.png). Hidden entries
and the --out folder (when it lies inside) are skipped with a printed notice. Nothing here
reads a file's contents: a FIFO can never block the listing.

A class of programs (collect_programs) has one program per student instead: a folder, or a
.zip / .tar.gz / .tgz / .tar file (the id is the name without that suffix); the same rules
hold for links, special files, names and two entries for one id.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from compare.sandbox.archives import ARCHIVE_SUFFIXES, archive_suffix
from compare.student_ids import displayable_name
from safe_files.paths import describe_mode

IMAGE_SUFFIXES = (".exr", ".png", ".ppm", ".pfm")


@dataclass
class Entry:
    student: str
    files: dict[str, str | None]
    problems: list[str] = field(default_factory=list)
    names: list[str] = field(default_factory=list)  # the entries that gave this id


def _not_regular_reason(mode: int, path: Path) -> str:
    if stat.S_ISLNK(mode):
        try:
            target = os.readlink(path)
        except OSError:
            target = "?"
        shown, _ = displayable_name(target)
        return f"is a symbolic link (to {shown}); hand in the file itself, links are not followed"
    return f"is {describe_mode(mode)}, not a regular file"


def _scene_files(folder: Path, scenes: list[str]) -> tuple[dict[str, str | None], list[str]]:
    """scene -> image in a student's folder, and the problems found (links, special files,
    two images for one scene)."""
    files: dict[str, str | None] = dict.fromkeys(scenes)
    problems: list[str] = []
    hits: dict[str, list[os.DirEntry[str]]] = {s: [] for s in scenes}
    try:
        with os.scandir(folder) as it:
            for e in it:
                stem, suffix = os.path.splitext(e.name)
                if stem in hits and suffix.lower() in IMAGE_SUFFIXES:
                    hits[stem].append(e)
    except OSError as err:
        return files, [f"cannot list the folder: {err.strerror}"]
    for scene, found in hits.items():
        found.sort(key=lambda e: e.name)
        if len(found) > 1:
            problems.append(
                f"{len(found)} images for scene '{scene}' ({', '.join(e.name for e in found)}); "
                "keep one"
            )
        elif found:
            mode = found[0].stat(follow_symlinks=False).st_mode
            if stat.S_ISREG(mode):
                files[scene] = found[0].path
            else:
                problems.append(f"{found[0].name} {_not_regular_reason(mode, Path(found[0].path))}")
    return files, problems


def collect_entries(
    submissions: Path,
    scenes: list[str],
    *,
    exclude: list[Path] | None = None,
    notice: Callable[[str], None] | None = None,
) -> list[Entry]:
    """One Entry per student id, sorted by id. ``exclude`` (the --out folder) and hidden
    entries are skipped, each with a notice."""
    by_id: dict[str, Entry] = {}
    for e, shown, bad_name, mode in _listing(submissions, exclude, notice):
        is_file_like = not stat.S_ISDIR(mode)
        student = os.path.splitext(shown)[0] if is_file_like else shown
        entry = by_id.setdefault(student, Entry(student, dict.fromkeys(scenes)))
        entry.names.append(shown)
        path = Path(e.path)
        if bad_name:
            entry.problems.append(f"the name {shown} {bad_name}; rename the file")
        elif stat.S_ISDIR(mode):
            entry.files, problems = _scene_files(path, scenes)
            entry.problems.extend(problems)
        elif not stat.S_ISREG(mode):
            entry.problems.append(f"{shown} {_not_regular_reason(mode, path)}")
        elif path.suffix.lower() not in IMAGE_SUFFIXES:
            entry.problems.append(
                f"unsupported file type '{path.suffix}' (expected {', '.join(IMAGE_SUFFIXES)})"
            )
        elif len(scenes) > 1:
            entry.problems.append(
                "one image for several scenes: hand in a folder with one image per scene"
            )
        else:
            entry.files[scenes[0]] = str(path)
    for entry in by_id.values():
        if len(entry.names) > 1:  # one id, one row: which file counts is not ours to guess
            entry.problems.insert(
                0,
                f"{len(entry.names)} submissions for one id ({', '.join(entry.names)}); keep one",
            )
    return [by_id[k] for k in sorted(by_id)]


def _listing(
    submissions: Path, exclude: list[Path] | None, notice: Callable[[str], None] | None
) -> Iterator[tuple[os.DirEntry[str], str, str | None, int]]:
    """(entry, displayable name, what is wrong with the name or None, lstat mode) of every entry to
    grade, in byte order of the names; the --out folder and hidden entries are skipped, each
    with a notice."""
    st = os.stat(submissions)  # follows a link given on the command line: the user's choice
    if not stat.S_ISDIR(st.st_mode):
        raise NotADirectoryError(f"{submissions}: not a folder of submissions")
    say = notice or (lambda _m: None)
    excluded = _identities(exclude)
    with os.scandir(submissions) as it:
        entries = sorted(it, key=lambda e: os.fsencode(e.name))
    for e in entries:
        shown, bad_name = displayable_name(e.name)
        mode = e.stat(follow_symlinks=False).st_mode
        if stat.S_ISDIR(mode) and _same(e, excluded):
            say(f"skipping {shown}/: it is the output folder")
        elif e.name.startswith("."):
            say(f"skipping hidden entry {shown} (rename it without the leading dot to grade it)")
        else:
            yield e, shown, bad_name, mode


def _same(e: os.DirEntry[str], excluded: set[tuple[int, int]]) -> bool:
    try:
        s = e.stat(follow_symlinks=False)
    except OSError:
        return False
    return (s.st_dev, s.st_ino) in excluded


@dataclass
class ProgramEntry:
    student: str
    source: str | None  # the folder or archive; None when there is none to build
    problems: list[str] = field(default_factory=list)
    names: list[str] = field(default_factory=list)


def collect_programs(
    submissions: Path,
    *,
    exclude: list[Path] | None = None,
    notice: Callable[[str], None] | None = None,
) -> list[ProgramEntry]:
    """One ProgramEntry per student id, sorted by id; skipped entries as in collect_entries."""
    by_id: dict[str, ProgramEntry] = {}
    for e, shown, bad_name, mode in _listing(submissions, exclude, notice):
        suffix = archive_suffix(shown) if not stat.S_ISDIR(mode) else None
        if stat.S_ISDIR(mode):
            student = shown
        else:  # alice.tar.gz and alice.ppm are both alice
            student = shown[: -len(suffix)] if suffix else os.path.splitext(shown)[0]
        entry = by_id.setdefault(student, ProgramEntry(student, None))
        entry.names.append(shown)
        if bad_name:
            entry.problems.append(f"the name {shown} {bad_name}; rename it")
        elif stat.S_ISDIR(mode) or (stat.S_ISREG(mode) and suffix):
            entry.source = e.path
        elif not stat.S_ISREG(mode):
            entry.problems.append(f"{shown} {_not_regular_reason(mode, Path(e.path))}")
        else:
            entry.problems.append(
                f"{shown} is not a program: hand in a folder or a "
                f"{', '.join(ARCHIVE_SUFFIXES)} file"
            )
    for entry in by_id.values():
        if len(entry.names) > 1:
            entry.problems.insert(
                0, f"{len(entry.names)} submissions for one id ({', '.join(entry.names)}); keep one"
            )
    return [by_id[k] for k in sorted(by_id)]


def _identities(paths: list[Path] | None) -> set[tuple[int, int]]:
    found = set()
    for p in paths or []:
        try:
            s = os.stat(p)
            found.add((s.st_dev, s.st_ino))
        except OSError:
            pass
    return found
