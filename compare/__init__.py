"""The judge: image I/O, metrics, reports and the `rtval` command line."""
