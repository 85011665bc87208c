"""Grading a class: submissions, their programs in the sandbox, scores, the gradebook and student pages."""
