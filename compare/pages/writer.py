"""Writing the HTML pages rtval makes (report, grade's student pages, check --html, stress):
one Jinja environment over compare/pages/templates with autoescape on (every value a template
prints is HTML-escaped unless the template says otherwise), the Content-Security-Policy of
compare/pages/security.py placed in every page, and an atomic write that only ever
replaces a regular file (safe_files/paths.py)."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

from jinja2 import Environment, PackageLoader, select_autoescape

from compare.pages.security import with_csp
from safe_files.paths import write_atomic


@functools.cache
def environment() -> Environment:
    """The templates' environment, made once per process (it caches compiled templates)."""
    env = Environment(
        loader=PackageLoader("compare.pages", "templates"),
        autoescape=select_autoescape(["html", "j2"]),
    )
    env.filters["num"] = number
    return env


def number(value: float | None, form: str) -> str:
    """A number in `form` (printf style), or "-" where it is undefined (null in a record)."""
    return "-" if value is None else form % value


def render_page(template: str, **context: Any) -> str:
    """The page `template` makes of `context`, with its Content-Security-Policy."""
    return with_csp(environment().get_template(template).render(**context))


def write_page(path: Path, template: str, **context: Any) -> None:
    """render_page(...) written to `path` atomically."""
    write_atomic(path, render_page(template, **context))
