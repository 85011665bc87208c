"""The Mitsuba side: the scene as Mitsuba XML with matching materials, the rtval_whitted
integrator, and reference renders (Whitted and path traced)."""
