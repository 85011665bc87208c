"""The report: the paper scene through every renderer, measured, charted and written as HTML and PDF."""
