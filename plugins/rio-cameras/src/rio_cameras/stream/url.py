"""What kind of source a `url` names, and how to print it without its password."""

from __future__ import annotations

import os
import re
from typing import Literal

Kind = Literal["pattern", "gstreamer", "network", "file"]

PATTERN = "test:pattern"
_NETWORK = re.compile(r"^(rtsp|rtsps|rtmp|http|https|udp|tcp|srt)://", re.IGNORECASE)
_CREDENTIALS = re.compile(r"^([a-z0-9+.-]+://)([^/@\s:]+):([^/@\s]*)@", re.IGNORECASE)


def classify(url: str) -> Kind:
    """`test:pattern`; a GStreamer pipeline (elements joined by ' ! ', ending in appsink); a network URL;
    otherwise a file: a video file, or an image sequence as a printf pattern (`frames/img_%04d.png`)."""
    if url.strip() == PATTERN:
        return "pattern"
    if " ! " in url:
        return "gstreamer"
    if _NETWORK.match(url.strip()):
        return "network"
    return "file"


def redact(url: str) -> str:
    """rtsp://admin:secret@10.0.0.5/stream -> rtsp://admin:***@10.0.0.5/stream (for logs and errors)."""
    return _CREDENTIALS.sub(r"\1\2:***@", url)


def file_exists(url: str) -> bool:
    """A file source exists: the file, or for a printf pattern its first frames' folder."""
    path = url[len("file://"):] if url.startswith("file://") else url
    if "%" in path:
        return os.path.isdir(os.path.dirname(path) or ".")
    return os.path.isfile(path)
