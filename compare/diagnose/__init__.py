"""The diagnosis: which changes to a demo model explain an image, and the evidence for them.

`diagnose(image, scene, render, DiagnoseOptions(...))` (search.py) is the entry point;
docs/diagnosis.md walks through the package."""

from compare.diagnose.search import DiagnoseOptions, Diagnosis, diagnose

__all__ = ["DiagnoseOptions", "Diagnosis", "diagnose"]
