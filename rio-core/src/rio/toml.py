"""Reading TOML with errors that point at the file and line (tomllib, or tomli on Python 3.10)."""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import Any

from rio.errors import ConfigError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on 3.10 only
    import tomli as tomllib

_AT = re.compile(r"\s*\(at line (\d+), column (\d+)\)\s*$")
_END = re.compile(r"\s*\(at end of document\)\s*$")


#: A station or config file is a few KB; anything this large is not one (and would cost memory to parse).
MAX_FILE_BYTES = 1 << 20


def read_text(path: Path) -> str:
    """A TOML file's text, or a one-line ConfigError for what cannot be one (too large, not UTF-8)."""
    size = path.stat().st_size
    if size > MAX_FILE_BYTES:
        raise ConfigError(f"{path}: {size} bytes is too large for a station or config file (limit "
                          f"{MAX_FILE_BYTES} bytes)")
    data = path.read_bytes()
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ConfigError(f"{path}: not UTF-8 text (byte 0x{data[e.start]:02x} at offset {e.start}): is this a "
                          "TOML file?") from None


def read_toml(path: str | Path) -> dict[str, Any]:
    """`parse_toml` of a file read with `read_text`."""
    return parse_toml(read_text(Path(path)), str(path))


def parse_toml(text: str, source: str) -> dict[str, Any]:
    """Parse `text`; a syntax error becomes `ConfigError("<source>:<line>:<col>: ...")`."""
    try:
        return tomllib.loads(text)
    except RecursionError:
        raise ConfigError(f"{source}: nested too deeply to be a station file (arrays or tables inside each other "
                          "hundreds of levels deep)") from None
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
