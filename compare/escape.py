"""Escaping user text (student ids, labels, file names, scene names) for the contexts it
lands in, other than HTML (Jinja's autoescape) and CSV (compare/csv_safe.py)."""

from __future__ import annotations

import json
from typing import Any

from compare.files import json_safe

# Inside <script> the HTML parser ends the element at "</script" whatever JSON thinks, and
# "<!--" changes the parsing state; U+2028/2029 end a line in older JavaScript. Written as
# \uXXXX escapes they mean the same to JSON.parse and nothing to the HTML parser.
_SCRIPT_UNSAFE = {
    "<": "\\u003c",
    ">": "\\u003e",
    "&": "\\u0026",
    "\u2028": "\\u2028",
    "\u2029": "\\u2029",
}


def json_for_script(obj: Any) -> str:
    """JSON text safe to embed in a <script> element (of type application/json)."""
    text = json.dumps(json_safe(obj), ensure_ascii=False, allow_nan=False)
    for ch, esc in _SCRIPT_UNSAFE.items():
        text = text.replace(ch, esc)
    return text


def mathtext_literal(text: str) -> str:
    """Text shown verbatim by matplotlib, which reads $...$ as mathtext (an unbalanced $
    raises, a balanced pair renders as maths)."""
    return text.replace("$", r"\$")
