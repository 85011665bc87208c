"""The placeholders of a renderer's command template: {scene}, {out}, {width}, ..."""

import re

PLACEHOLDER = re.compile(r"\{([^{}]*)\}")


def fill(word: str, values: dict[str, str]) -> str:
    """One word of the template with each placeholder replaced by its value."""
    return PLACEHOLDER.sub(lambda m: values[m.group(1)], word)
