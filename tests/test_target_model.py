"""The target-model syntax (compare/judge/target_model.py): parsing, canonical names and the
rtdemo options each model renders with."""

from __future__ import annotations

import pytest

from compare.judge.target_model import ModelError, parse_model


@pytest.mark.parametrize(
    ("text", "name", "args"),
    [
        ("classic", "classic", ["--mode", "classic"]),
        ("Classic+Q2", "classic+Q2", ["--mode", "classic", "--quirk", "Q2"]),
        ("paper-Q8", "paper-Q8", ["--mode", "paper", "--fix", "Q8"]),
        ("paper-q8-q1", "paper-Q1-Q8", ["--mode", "paper", "--fix", "Q1,Q8"]),
        ("physical+Q7+Q10", "physical+Q7+Q10", ["--mode", "physical", "--quirk", "Q7,Q10"]),
        # A toggle that restates the mode's own set changes nothing.
        ("classic+Q1", "classic", ["--mode", "classic"]),
        ("classic+Q2-Q2", "classic", ["--mode", "classic"]),
    ],
)
def test_demo_models(text: str, name: str, args: list[str]) -> None:
    model = parse_model(text)
    assert model.is_demo and model.name == name and model.rtdemo_args() == args
    assert parse_model(model.name) == model  # the canonical name parses back to itself


def test_mitsuba_models() -> None:
    assert parse_model("mitsuba").name == "mitsuba" and not parse_model("mitsuba").is_demo
    assert parse_model("mitsuba-path").kind == "mitsuba-path"
    with pytest.raises(ModelError, match="not a demo model"):
        parse_model("mitsuba").rtdemo_args()


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("whitted", "unknown model 'whitted'"),
        ("classic+Q14", "no quirk Q14"),
        ("classic+Q0", "no quirk Q0"),
        ("classic Q2", "unknown model"),
        ("classic+", "unknown model"),
        ("", "unknown model"),
    ],
)
def test_bad_models_name_the_syntax(text: str, message: str) -> None:
    with pytest.raises(ModelError, match=message):
        parse_model(text)
