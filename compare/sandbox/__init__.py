"""Running untrusted programs: the bubblewrap sandbox, its outputs, and unpacking submitted archives."""
