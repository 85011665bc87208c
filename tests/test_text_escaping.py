"""User text through the CSV and the HTML, for any text (Hypothesis): what a CSV reader
reads back is the text, neutralised; the HTML holds no markup from it; JSON embedded in a
script cannot end the script and parses back to the same data; slugs are safe and unique."""

from __future__ import annotations

import csv
import io
import json
import re

from hypothesis import given, settings
from hypothesis import strategies as st
from jinja2 import Environment, PackageLoader, select_autoescape

from compare.escape import json_for_script
from compare.grading.csv_safe import FORMULA_TRIGGERS, csv_text, neutralise
from compare.pages.security import content_security_policy, printable, with_csp
from compare.student_ids import student_slug

# Names as file names can hold them (no "/" or NUL) and labels as a shell can pass them.
names = st.text(
    st.characters(blacklist_characters="/\x00", blacklist_categories=("Cs",)), min_size=1
)
HOSTILE = [
    "=1+2",
    "+cmd",
    "@SUM(1+1)",
    "-2+3",
    "\tx",
    "\rx",
    "</script><script>alert(1)</script>",
    'a"b,c\nd',
]


@settings(max_examples=300, deadline=None)
@given(names)
def test_csv_round_trip_is_the_name_neutralised(name: str) -> None:
    text = csv_text([["student", "status"], [name, "pass"]])
    rows = list(csv.reader(io.StringIO(text, newline="")))
    assert rows[1] == [neutralise(name), "pass"]
    cell = rows[1][0]
    assert cell in (name, "'" + name)  # the name itself, at most behind an apostrophe
    assert not cell.startswith(FORMULA_TRIGGERS) or re.fullmatch(r"[-+][0-9.eE+-]+", cell)


def test_known_formulas_are_neutralised() -> None:
    for name in HOSTILE[:6]:
        assert neutralise(name) == "'" + name
    assert neutralise("-0.5") == "-0.5" and neutralise("alice") == "alice"


def _student_page(student: str) -> str:
    env = Environment(
        loader=PackageLoader("compare.pages", "templates"),
        autoescape=select_autoescape(["html", "j2"]),
    )
    r = {
        "student": student,
        "status": "fail",
        "score": 0.0,
        "rubric": student,
        "scenes": [{"scene": "classic", "status": "error", "score": 0.0, "reason": student}],
    }
    return with_csp(env.get_template("student.html.j2").render(r=r))


@settings(max_examples=200, deadline=None)
@given(st.one_of(names, st.sampled_from(HOSTILE)))
def test_student_page_holds_no_markup_from_the_name(name: str) -> None:
    page = _student_page(name)
    blank = _student_page("x")
    # Every tag in the page is one of the template's own: the name adds none.
    tags = lambda html: re.findall(r"<[a-zA-Z/!][^>]*>", html)  # noqa: E731
    assert len(tags(page)) == len(tags(blank))
    assert "<script" not in page.lower()


@settings(max_examples=300, deadline=None)
@given(st.one_of(names, st.sampled_from(HOSTILE)))
def test_json_in_a_script_cannot_end_it_and_parses_back(label: str) -> None:
    data = [{"label": label, "png": "images/a.png"}]
    text = json_for_script(data)
    assert "<" not in text and ">" not in text and "&" not in text
    assert "\u2028" not in text and "\u2029" not in text
    assert json.loads(text) == data


def test_csp_allows_exactly_the_pages_own_scripts() -> None:
    html = "<html><head><title>t</title></head><body><script>let a = 1;</script></body></html>"
    csp = content_security_policy(html)
    # printf 'let a = 1;' | openssl dgst -sha256 -binary | base64
    assert "script-src 'sha256-xY6QKfH9PRsQnLz56nj6MBwiK5oHg+im1Jkpdp1x/Ck='" in csp
    assert "default-src 'none'" in csp
    assert "'unsafe-inline'" not in csp.split("script-src")[1].split(";")[0]
    out = printable(with_csp(html))
    assert (
        "<script" not in out and "script-src 'none'" in out and out.count("Content-Security") == 1
    )


@settings(max_examples=300, deadline=None)
@given(names, names)
def test_slugs_are_safe_and_distinct(a: str, b: str) -> None:
    sa, sb = student_slug(a), student_slug(b)
    for s in (sa, sb):
        assert re.fullmatch(r"[a-z0-9_][a-z0-9_-]*(\.[0-9a-f]{10})?", s) and len(s) <= 80
    if a != b:
        assert sa != sb and sa.lower() != sb.lower()
