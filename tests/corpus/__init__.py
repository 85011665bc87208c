"""A corpus of foreign programs of the classic and paper models (see programs.py)."""
