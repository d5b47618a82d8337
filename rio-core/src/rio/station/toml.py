"""Reading TOML with errors that point at the file and line (tomllib, or tomli on Python 3.10)."""

from __future__ import annotations

import re
import sys
from typing import Any

from ..errors import ConfigError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on 3.10 only
    import tomli as tomllib

_AT = re.compile(r"\s*\(at line (\d+), column (\d+)\)\s*$")
_END = re.compile(r"\s*\(at end of document\)\s*$")


def parse_toml(text: str, source: str) -> dict[str, Any]:
    """Parse `text`; a syntax error becomes `ConfigError("<source>:<line>:<col>: ...")`."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        msg = str(getattr(e, "msg", None) or e)
        line, col = getattr(e, "lineno", None), getattr(e, "colno", None)
        lines = text.splitlines()
        m = _AT.search(str(e))
        if m:
            line, col = int(m.group(1)), int(m.group(2))
            msg = _AT.sub("", msg)
        elif _END.search(msg):  # e.g. an unclosed array: point after the last character
            line, col = max(len(lines), 1), len(lines[-1]) + 1 if lines else 1
            msg = _END.sub(" (at end of file)", msg)
        if line is None:
            raise ConfigError(f"{source}: TOML syntax error: {msg}") from None
        shown = f"\n    {lines[line - 1]}\n    {' ' * (max(col or 1, 1) - 1)}^" if 0 < line <= len(lines) else ""
        raise ConfigError(f"{source}:{line}:{col}: TOML syntax error: {msg}{shown}") from None
