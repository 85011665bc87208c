"""compare.code_identity: the one key of every result kept between runs, from the import graph."""

from __future__ import annotations

from pathlib import Path

from compare.code_identity import ROOT, _identity, covered_files


def _tree(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def _files(root: Path, *modules: str) -> set[str]:
    return {str(p.relative_to(root)) for p in covered_files(root, modules)}


def test_an_import_anywhere_in_a_module_is_covered_and_nothing_else(tmp_path: Path) -> None:
    _tree(
        tmp_path,
        {
            "compare/__init__.py": "from compare.big import everything\n",
            "compare/big.py": "",
            "compare/a.py": "from compare import b\n",
            "compare/b.py": "def f():\n    from compare.c import g\n",
            "compare/c.py": "import numpy\ng = 1\n",
            "compare/unrelated.py": "",
            "compare/table.json": "{}",
        },
    )
    assert _files(tmp_path, "compare.a") == {
        "compare/a.py",
        "compare/b.py",
        "compare/c.py",
        "compare/table.json",
    }


def test_a_change_to_an_imported_module_changes_the_identity(tmp_path: Path) -> None:
    _tree(tmp_path, {"compare/a.py": "import compare.b\n", "compare/b.py": "X = 1\n"})
    _tree(tmp_path / "other", {"compare/a.py": "import compare.b\n", "compare/b.py": "X = 2\n"})
    _tree(tmp_path / "same", {"compare/a.py": "import compare.b\n", "compare/b.py": "X = 1\n"})
    first = _identity(tmp_path, ("compare.a",), ())
    assert _identity(tmp_path / "other", ("compare.a",), ()) != first
    assert _identity(tmp_path / "same", ("compare.a",), ()) == first


def test_the_diagnosis_is_keyed_by_what_it_decides_with() -> None:
    covered = _files(ROOT, "compare.diagnose.search")
    assert {
        "compare/diagnose/search.py",
        "compare/diagnose/score.py",
        "compare/diagnose/mistakes.json",
        "compare/judge/exact_match.py",
        "compare/judge/effects.py",
    } <= covered
    # The report and grading are not part of it: their changes keep kept diagnoses valid.
    assert not any(f.startswith(("compare/report/", "compare/grading/")) for f in covered)


def test_the_report_metrics_are_keyed_by_the_judge_only() -> None:
    roots = ("evaluate", "effects", "convergence", "penumbra", "pareto", "scoring", "sentences")
    covered = _files(ROOT, *(f"compare.judge.{m}" for m in roots))
    assert {"compare/judge/metrics.py", "compare/judge/images.py"} <= covered
    assert not any(f.startswith("compare/diagnose/") for f in covered)
    assert "compare/judge/rubric.py" not in covered
