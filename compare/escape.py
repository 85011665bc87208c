"""Escaping user text (student ids, labels, file names, scene names) for the contexts it
lands in, other than HTML (Jinja's autoescape) and CSV (compare/grading/csv_safe.py)."""

from __future__ import annotations

import json
import re
from typing import Any

from safe_files.content import json_safe

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


def markdown_cell(text: str) -> str:
    """Text for one Markdown table cell or list item: no HTML (GitHub renders some), no pipe
    that would end the cell, no line break that would end the row."""
    return (
        text.replace("&", "&amp;")
        .replace("<", "&lt;")
        .replace(">", "&gt;")
        .replace("|", "\\|")
        .replace("\r", " ")
        .replace("\n", " ")
    )


# XML 1.0 allows tab, newline and carriage return but no other C0 control (ElementTree writes
# them anyway, and a JUnit reader then rejects the whole file), no surrogate, no U+FFFE/FFFF.
_XML_FORBIDDEN = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


def xml_text(text: str) -> str:
    """Text ElementTree may write as an XML 1.0 attribute or element (it escapes & < > and
    quotes itself): each character XML cannot hold becomes U+FFFD."""
    return _XML_FORBIDDEN.sub("\ufffd", text)
