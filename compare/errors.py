"""The error every part of compare raises when an outside program cannot be found or fails."""


class ToolError(RuntimeError):
    """A renderer could not be found or failed; the message says which and why."""
