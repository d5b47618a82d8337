"""The dataset index (dataset.json): the list of finished episodes and dataset-wide facts.

It is a cache of the episodes' own episode.json files, rewritten atomically after every kept
episode, so a reader never sees half an index. If a crash falls between an episode's rename and
the index rewrite, the episode is complete on disk but missing here; `rebuild` (run by
`rio datasets repair`) restores it from the directories.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

from . import paths as L
from .durable import write_json_atomic


def summary(meta: dict[str, Any]) -> dict[str, Any]:
    """The index entry of an episode, from its episode.json."""
    keys = ("index", "dir", "length", "fps", "duration_s", "instruction", "t_start", "finished_at", "repaired")
    out = {k: meta[k] for k in keys if k in meta}
    out["cameras"] = {k: {f: v[f] for f in ("frames", "height", "width", "rate") if f in v}
                      for k, v in meta.get("streams", {}).items()}
    return out


def empty(root: Path) -> dict[str, Any]:
    now = time.strftime("%Y-%m-%dT%H:%M:%S")
    return {"format": L.FORMAT, "version": L.VERSION, "name": root.name, "created": now, "updated": now,
            "fps": None, "station": None, "embodiment": None, "total_steps": 0, "episodes": []}


def load(root: Path) -> dict[str, Any]:
    path = root / L.INDEX
    if not path.exists():
        return empty(root)
    data = json.loads(path.read_text())
    if data.get("format") != L.FORMAT:
        raise ValueError(f"{path} is not a RIO dataset index (format {data.get('format')!r})")
    return data


def add_episode(index: dict[str, Any], meta: dict[str, Any]) -> dict[str, Any]:
    eps = [e for e in index["episodes"] if e["index"] != meta["index"]]
    eps.append(summary(meta))
    eps.sort(key=lambda e: e["index"])
    index["episodes"] = eps
    index["total_steps"] = sum(e.get("length", 0) for e in eps)
    for key in ("fps", "station", "embodiment"):
        if index.get(key) is None and meta.get(key) is not None:
            index[key] = meta[key]
    index["updated"] = time.strftime("%Y-%m-%dT%H:%M:%S")
    return index


def save(root: Path, index: dict[str, Any]) -> None:
    write_json_atomic(root / L.INDEX, index)


def rebuild(root: Path) -> tuple[dict[str, Any], list[str]]:
    """An index made from the finished episode directories; also what changed, in words."""
    old = load(root) if (root / L.INDEX).exists() else empty(root)
    new = empty(root)
    for k in ("name", "created"):
        new[k] = old.get(k, new[k])
    notes: list[str] = []
    known = {e["index"] for e in old["episodes"]}
    for idx, (path, partial) in L.scan(root).items():
        if partial or not (path / L.EPISODE_META).exists():
            continue
        meta = json.loads((path / L.EPISODE_META).read_text())
        add_episode(new, meta)
        if idx not in known:
            notes.append(f"added {path.name} (finished but missing from the index)")
    for e in old["episodes"]:
        if e["index"] not in {x["index"] for x in new["episodes"]}:
            notes.append(f"dropped {e.get('dir')} from the index (its directory is missing)")
    return new, notes
