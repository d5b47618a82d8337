"""The dataset index (dataset.json): the list of finished episodes and dataset-wide facts.

It is a cache of the episodes' own episode.json files, rewritten atomically after every kept
episode, so a reader never sees half an index. If a crash falls between an episode's rename and
the index rewrite, the episode is complete on disk but missing here; `rebuild` (run by
`rio datasets repair`) restores it from the directories.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from rio.errors import ConfigError, RioError
from rio.recording import paths as L
from rio.recording.durable import read_json, write_json_atomic


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
    """The index; a damaged or foreign dataset.json is one ConfigError naming it (repair rebuilds it)."""
    path = root / L.INDEX
    if not path.exists():
        return empty(root)
    data = read_json(path)
    hint = f"; `rio datasets repair {root}` rebuilds it from the episode directories"
    if not isinstance(data, dict) or data.get("format") != L.FORMAT:
        found = data.get("format") if isinstance(data, dict) else type(data).__name__
        raise ConfigError(f"{path} is not a RIO dataset index (format {found!r}){hint}")
    eps = data.get("episodes")
    if not isinstance(eps, list) or not all(isinstance(e, dict) and isinstance(e.get("index"), int)
                                            and isinstance(e.get("dir"), str) for e in eps):
        raise ConfigError(f"{path}: damaged (its episode list is not a list of {{index, dir}} entries){hint}")
    return data


def load_episode_meta(path: Path) -> dict[str, Any]:
    """An episode directory's episode.json; damaged (or not an episode's) is one ConfigError naming it."""
    meta_path = path / L.EPISODE_META
    meta = read_json(meta_path)
    if not isinstance(meta, dict) or not isinstance(meta.get("index"), int) or not isinstance(meta.get("length"), int) \
            or not isinstance(meta.get("fps"), (int, float)):
        raise ConfigError(f"{meta_path}: damaged (not an episode's metadata: index, length and fps are required)")
    meta.setdefault("dir", path.name)
    return meta


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


def rebuild(root: Path, *, salvage: bool = False) -> tuple[dict[str, Any], list[str]]:
    """An index made from the finished episode directories; also what changed, in words.
    A damaged dataset.json or episode.json raises (ConfigError naming it), unless `salvage` (repair):
    then a damaged index is rebuilt from scratch and a damaged episode left out, both noted."""
    notes: list[str] = []
    try:
        old = load(root)
    except RioError as err:
        if not salvage:
            raise
        old = empty(root)
        notes.append(f"rebuilt from the episode directories ({err})")
    new = empty(root)
    for k in ("name", "created"):
        new[k] = old.get(k, new[k])
    known = {e["index"] for e in old["episodes"]}
    for idx, (path, partial) in L.scan(root).items():
        if partial or not (path / L.EPISODE_META).exists():
            continue
        try:
            meta = load_episode_meta(path)
        except RioError as err:
            if not salvage:
                raise
            notes.append(f"left out {path.name} ({err})")
            continue
        add_episode(new, meta)
        if idx not in known:
            notes.append(f"added {path.name} (finished but missing from the index)")
    for e in old["episodes"]:
        if e["index"] not in {x["index"] for x in new["episodes"]}:
            notes.append(f"dropped {e.get('dir')} from the index (its directory is missing)")
    return new, notes
