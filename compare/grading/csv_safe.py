"""CSV cells that a spreadsheet will not evaluate (OWASP "CSV injection").

A cell starting with = + - @ (or a tab or carriage return, which some spreadsheets skip
before looking for those) is read as a formula. Such a cell gets a leading apostrophe,
which spreadsheets show as text and which a CSV reader returns as part of the value (so
what a reader gets back is neutralise(text)); the csv module's quoting takes care of
separators, quotes and newlines.
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Iterable

FORMULA_TRIGGERS = ("=", "+", "-", "@", "\t", "\r")
_PLAIN_NUMBER = re.compile(r"[-+]?[0-9]+(\.[0-9]+)?([eE][-+]?[0-9]+)?")


def neutralise(cell: str) -> str:
    """The cell as text a spreadsheet shows verbatim (a plain number such as -0.5 is no
    formula and stays a number)."""
    if cell.startswith(FORMULA_TRIGGERS) and not _PLAIN_NUMBER.fullmatch(cell):
        return "'" + cell
    return cell


def csv_text(rows: Iterable[Iterable[object]]) -> str:
    """CSV of ``rows``; text cells are neutralised, numbers written as they are."""
    buf = io.StringIO()
    w = csv.writer(buf)
    for row in rows:
        w.writerow([neutralise(c) if isinstance(c, str) else c for c in row])
    return buf.getvalue()
