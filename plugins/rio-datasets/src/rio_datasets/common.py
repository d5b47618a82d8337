"""What every exporter needs from a native dataset: the episodes asked for, one rate, the
low-dimensional columns under stable names, and the camera streams (one frame per step)."""

from __future__ import annotations

from typing import Any

import numpy as np

from rio.errors import RioError
from rio.recording import Dataset, Episode


class ExportError(RioError):
    pass


def select(ds: Dataset, episodes: list[int] | None) -> list[Episode]:
    """The episodes to export, each verified first: a damaged one raises DamagedEpisode before
    anything is written (unless `ds` allows damaged episodes; the check is cached per dataset)."""
    eps = [ds.episode(k) for k in episodes] if episodes is not None else list(ds)
    if not eps:
        raise ExportError(f"{ds.root}: no episodes to export")
    for ep in eps:
        ep.check()
    return eps


def common_fps(eps: list[Episode]) -> float:
    rates = {e.fps for e in eps}
    if len(rates) != 1:
        raise ExportError(f"episodes were recorded at different rates {sorted(rates)}; export them separately")
    return rates.pop()


def lowdim(ep: Episode) -> dict[str, np.ndarray]:
    """{"action", "proprio", "proprio_eef", ..., "t"}: the numeric columns, (T, ...) each."""
    out = ep.observation_columns()
    if "action" in ep.schema.names:
        out["action"] = ep.column("action")
    out["t"] = ep.column("t")
    return out


def image_streams(ep: Episode, depth: bool = True) -> list[tuple[str, str]]:
    """(camera, kind) pairs, sorted, depth included only if asked."""
    return sorted((s["camera"], s["kind"]) for s in ep.streams.values() if depth or s["kind"] == "rgb")


def rio_attrs(ep: Episode) -> dict[str, Any]:
    """What a RIO import needs to rebuild the episode exactly (stored as an attribute / JSON)."""
    keys = ("fps", "instruction", "station", "embodiment", "action_names", "action_parts", "observation_class")
    out = {k: ep.meta.get(k) for k in keys if ep.meta.get(k) is not None}
    out["index"] = ep.index
    out["streams"] = {k: {f: v.get(f) for f in ("camera", "kind", "height", "width", "rate", "depth_unit_m")}
                      for k, v in ep.streams.items()}
    return out


def absent_streams(ep: Episode) -> list[str]:
    """Camera streams ('front.rgb') a merged episode lacks (`rio datasets merge`: no files, -1 frame
    indices, listed under merge.absent_streams); empty for any other episode."""
    merge = ep.meta.get("merge")
    return list(merge.get("absent_streams", [])) if isinstance(merge, dict) else []


def check_same_layout(eps: list[Episode], absent_ok: bool = False) -> None:
    """Same step layout and camera streams in every episode; with `absent_ok`, a stream a merged
    episode declares absent counts as present (the exporter fills it in)."""
    first = eps[0]

    def streams(e: Episode) -> list[str]:
        return sorted(set(e.streams) | (set(absent_streams(e)) if absent_ok else set()))

    for e in eps[1:]:
        if e.schema.fields != first.schema.fields:
            raise ExportError(f"episode {e.index} has a different step layout than episode {first.index}; "
                              "export them separately")
        if streams(e) != streams(first):
            raise ExportError(f"episode {e.index} has cameras {sorted(e.streams)}, episode {first.index} has "
                              f"{sorted(first.streams)}")
