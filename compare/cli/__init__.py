"""The `rtval` command line, one module per command (entry point: compare.cli.main:main)."""
