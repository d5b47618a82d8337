"""Small lookups into OpenCV's constants, imported lazily (OpenCV is not needed to list drivers)."""

from __future__ import annotations


def cv2_prop(name: str) -> int:
    """'autofocus' -> cv2.CAP_PROP_AUTOFOCUS; a name OpenCV does not know is a ValueError listing a few."""
    import cv2

    attr = "CAP_PROP_" + name.strip().upper()
    if not hasattr(cv2, attr):
        known = sorted(n[9:].lower() for n in dir(cv2) if n.startswith("CAP_PROP_") and "_" not in n[9:])[:40]
        raise ValueError(f"unknown capture control {name!r}; OpenCV's include: {', '.join(known)}")
    return int(getattr(cv2, attr))
