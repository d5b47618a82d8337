"""The dataset index (dataset.json): the list of finished episodes and dataset-wide facts.

It is a cache of the episodes' own episode.json files, rewritten atomically after every kept
episode, so a reader never sees half an index. If a crash falls between an episode's rename and
the index rewrite, the episode is complete on disk but missing here; `rebuild` (run by
`rio datasets repair`) restores it from the directories.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

from rio.errors import ConfigError, RioError
from rio.recording import paths as L
from rio.recording.checks import metadata_problems
from rio.recording.durable import read_json, write_json_atomic


def summary(meta: dict[str, Any]) -> dict[str, Any]:
    """The index entry of an episode, from its episode.json."""
    keys = ("index", "dir", "length", "fps", "duration_s", "instruction", "t_start", "finished_at", "repaired")
    out = {k: meta[k] for k in keys if k in meta}
    out["cameras"] = {k: {f: v[f] for f in ("frames", "height", "width", "rate", "measured_rate")
                          if f in v}
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
    for k, e in enumerate(eps):
        if bad := _entry_problem(e):
            raise ConfigError(f"{path}: damaged (episodes[{k}].{bad}){hint}")
    return data


def _entry_problem(entry: dict[str, Any]) -> str | None:
    """What is wrong with the values of one index entry that `rio datasets info` shows (None: nothing)."""
    def number(v: Any) -> bool:
        return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)

    if "length" in entry and not (isinstance(entry["length"], int) and entry["length"] >= 0):
        return f"length: {entry['length']!r} is not a number of steps"
    for key in ("duration_s", "fps"):
        if entry.get(key) is not None and not number(entry[key]):
            return f"{key}: {entry[key]!r} is not a finite number"
    if entry.get("instruction") is not None and not isinstance(entry["instruction"], str):
        return f"instruction: a {type(entry['instruction']).__name__}, not text"
    cams = entry.get("cameras", {})
    if not isinstance(cams, dict) or not all(isinstance(v, dict) for v in cams.values()):
        return "cameras: not a table of camera streams"
    return None


def load_episode_meta(path: Path) -> dict[str, Any]:
    """An episode directory's episode.json; damaged, not an episode's, or holding impossible values
    (`checks.metadata_problems`: fps 0, a stream of an unknown kind) is one ConfigError naming it."""
    meta_path = path / L.EPISODE_META
    meta = read_json(meta_path)
    if not isinstance(meta, dict) or not all(k in meta for k in ("index", "length", "fps")):
        raise ConfigError(f"{meta_path}: damaged (not an episode's metadata: index, length and fps are required)")
    problems = metadata_problems(meta)
    if problems:
        raise ConfigError(f"{meta_path}: damaged (impossible values: {'; '.join(problems)})")
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
            there = "\x00" not in e["dir"] and (root / e["dir"]).exists() and L.escapes(root, root / e["dir"])
            notes.append(f"dropped {e.get('dir')} from the index (" + ("it points outside the dataset)" if there
                                                                        else "its directory is missing)"))
    return new, notes
