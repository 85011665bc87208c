"""A Content-Security-Policy for the pages rtval writes.

The pages carry their own script (the report's flip control) and their data as inert
JSON (<script type="application/json">, escaped by compare.escape.json_for_script). The
policy allows exactly the inline scripts that the template wrote, by hash, so text that
slipped into the page as markup could still not run; no network, no plugins, no forms.
"""

from __future__ import annotations

import base64
import hashlib
import re

_INLINE_SCRIPT = re.compile(r"<script>(.*?)</script>", re.DOTALL)  # JS only: no type attribute
_ANY_SCRIPT = re.compile(r"<script\b[^>]*>.*?</script>", re.DOTALL | re.IGNORECASE)
_CSP_META = re.compile(r'<meta http-equiv="Content-Security-Policy"[^>]*>\n?')
_HEAD = re.compile(r"<head[^>]*>", re.IGNORECASE)


def content_security_policy(html: str) -> str:
    hashes = [
        "'sha256-" + base64.b64encode(hashlib.sha256(m.group(1).encode()).digest()).decode() + "'"
        for m in _INLINE_SCRIPT.finditer(html)
    ]
    return "; ".join(
        [
            "default-src 'none'",
            "img-src 'self' file: data:",  # the report's images, opened from disk or served
            "style-src 'unsafe-inline'",  # the template's own <style>; styles run no code
            "script-src " + (" ".join(hashes) if hashes else "'none'"),
            "object-src 'none'",
            "base-uri 'none'",
            "form-action 'none'",
        ]
    )


def with_csp(html: str) -> str:
    """``html`` with a CSP <meta> as the first element of <head> (it must precede every
    script it governs)."""
    meta = f'<meta http-equiv="Content-Security-Policy" content="{content_security_policy(html)}">'
    m = _HEAD.search(html)
    if m is None:
        raise ValueError("page has no <head>: cannot place its Content-Security-Policy")
    return html[: m.end()] + "\n" + meta + html[m.end() :]


def printable(html: str) -> str:
    """The page without any script (its data and its interactive control), under a policy
    that allows none: what Chromium prints to PDF, so that printing (as root, where
    Chromium cannot sandbox itself) never runs a script, whatever the page holds."""
    return with_csp(_ANY_SCRIPT.sub("", _CSP_META.sub("", html)))
