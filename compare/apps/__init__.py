"""The applications built on the judge: compare, check, report, grade and stress. They run
renderers (compare.render) and write HTML, CSV and JSON."""
