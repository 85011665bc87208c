"""Scene loading for Python, Mitsuba XML export and reference rendering."""
