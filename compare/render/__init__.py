"""Running the renderers (rtdemo, Mitsuba through `rtval reference`) as commands, and caching
their outputs by content hash."""
