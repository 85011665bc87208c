"""Safe file handling for every package: input checks, bounded reads, atomic writes, own folders."""
