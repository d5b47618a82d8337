"""Merge native datasets of different morphologies (single-arm, bimanual, humanoid; any DOF and camera
set) into one native dataset with a padded layout: `rio datasets merge A B ... OUT`.

Every merged episode has the same step layout (`steps.json` fields), so every reader and exporter sees
one schema:

- **fields**: the union of the inputs' step columns (`obs.*`, `action`, numeric `meta.*`, `cam.*`).
  A field whose size differs between inputs is padded to the largest size (per axis; a scalar counts
  as size 1) with zeros after the real values, which keep their place at the start; a field an input
  lacks is all zeros there. Its dtype is the one numpy promotes the inputs' dtypes to (float32 and
  float64 give float64, so the real values stay exact).
- **masks**, per episode, in `episode.json` under `merge.fields`: for every field but `timestep`,
  `t`, `t_recv` and `cam.*`, the shape the source had (`null`: it had none) and a boolean mask of the
  merged shape, true where an entry is real. `real_values(ep, name)` gives back the source's array.
- **embodiment tag**, per episode, under `merge.embodiment`: station, embodiment name, action space
  (from the recorded action parts: `joint_pos`, `eef_pose`), action parts, observation class, and
  `tag` = `embodiment@station:action_space`. `rio datasets info` shows how many episodes each tag has.
- **cameras**: the union of the camera streams. An episode keeps the streams it had, their video and
  frame files copied byte for byte; a stream it lacks is not padded with images: it has no files, its
  `cam.<name>.<kind>` column is -1 at every step (the "no frame" value), and it is listed under
  `merge.absent_streams` (and the camera under `merge.absent_cameras` when it has no stream at all).
- The episode's own metadata (station, embodiment, instruction, streams, observation class...) is
  kept; `merge.source` says where it came from. `steps.bin`, `steps.json`, `recording.json` and
  `episode.json` are rewritten, every other file is copied and its recorded sha256 checked on the copy.

Refused, with one line and nothing written: fewer than two inputs, an input given twice, an input that
is not a dataset or has no finished episode, a damaged episode (`DamagedEpisode`), inputs recorded at
different rates (nothing is resampled), a field whose shapes cannot be padded into one (different
numbers of axes), an OUT that exists and is not empty, or lies inside an input. The inputs are only
read. A merge that fails removes what it wrote.
"""

from __future__ import annotations

import copy
import hashlib
import json
import os
import re
import shutil
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rio.machine.confine import inside
from rio.recording import index as I
from rio.recording import paths as L
from rio.recording.dataset import DamagedEpisode, Dataset, DatasetError, Episode
from rio.recording.durable import fsync_dir, write_json_atomic
from rio.recording.flatten import StepSchema

#: progress(line): one line per input dataset as the merge advances (the CLI prints it on stderr)
MergeProgress = Callable[[str], None]

#: columns every episode has, never padded nor masked
_ALWAYS = ("timestep", "t", "t_recv")
_ARM_SPACES = ("joint_pos", "eef_pose")


class MergeError(DatasetError):
    pass


# -- embodiment tags --------------------------------------------------------------------------------
def _snake(name: str) -> str:
    return re.sub(r"(?<!^)(?=[A-Z])", "_", name).lower()


def embodiment_of(meta: dict[str, Any]) -> dict[str, Any]:
    """The embodiment tag of an episode from its episode.json: station, embodiment name (else one
    derived from its observation class: SingleArmObs -> single_arm), action space, action parts."""
    merged = meta.get("merge")
    if isinstance(merged, dict) and isinstance(merged.get("embodiment"), dict) \
            and isinstance(merged["embodiment"].get("tag"), str):
        return merged["embodiment"]
    obs_class = meta.get("observation_class")
    embodiment = meta.get("embodiment")
    if embodiment is not None and not isinstance(embodiment, str):
        embodiment = str(embodiment)
    if not embodiment and isinstance(obs_class, str):
        embodiment = _snake(obs_class.rpartition(":")[2]).removesuffix("_obs") or None
    parts = meta.get("action_parts")
    spaces: list[str] = []
    if isinstance(parts, list):
        for part in parts:
            label = str(part[0]) if isinstance(part, (list, tuple)) and part else ""
            space = next((s for s in _ARM_SPACES if label.endswith(s)), None)
            if space is not None and space not in spaces:
                spaces.append(space)
    action_space = "+".join(spaces) or None
    try:
        action_dim: int | None = sum(int(p[1]) for p in parts) if isinstance(parts, list) else None
    except (TypeError, ValueError, IndexError):  # metadata written by something else: no dimension then
        action_dim = None
    station = meta.get("station")
    tag = f"{embodiment or 'unknown'}@{station or 'unknown'}" + (f":{action_space}" if action_space else "")
    return {"tag": tag, "station": station, "embodiment": embodiment, "action_space": action_space,
            "action_parts": parts, "action_dim": action_dim,
            "observation_class": obs_class}


def embodiment_mix(dataset: Dataset) -> dict[str, int]:
    """{embodiment tag: episodes} of a dataset (merged or not), from the episodes' metadata only; an
    episode whose episode.json cannot be read is left out (`info` reports it as damaged)."""
    from rio.errors import RioError

    out: dict[str, int] = {}
    for e in dataset.episodes:
        try:
            tag = embodiment_of(I.load_episode_meta(dataset.episode_dir(e)))["tag"]
        except RioError:
            continue
        out[tag] = out.get(tag, 0) + 1
    return out


# -- reading a merged episode -----------------------------------------------------------------------
def merge_info(ep: Episode) -> dict[str, Any] | None:
    """The `merge` part of an episode's metadata (None: not a merged episode)."""
    info = ep.meta.get("merge")
    return info if isinstance(info, dict) else None


def mask(ep: Episode, name: str) -> np.ndarray:
    """The boolean mask of field `name` (merged shape, true where real); all true when not merged."""
    info = merge_info(ep)
    shape = ep.schema.dtype[name].shape
    if info is None or name not in info.get("fields", {}):
        return np.ones(shape, bool)
    return np.asarray(info["fields"][name]["mask"], bool).reshape(shape)


def real_values(ep: Episode, name: str) -> np.ndarray | None:
    """Column `name` as its source recorded it: the padding cut off, the source's shape and dtype
    (None: the source had no such field). The same as `ep.column(name)` for an unmerged episode."""
    col = ep.column(name)
    info = merge_info(ep)
    if info is None or name not in info.get("fields", {}):
        return col
    f = info["fields"][name]
    if f["shape"] is None:
        return None
    shape = tuple(f["shape"])
    region = _region(shape, col.shape[1:])
    return col[(slice(None),) + region].reshape(len(col), *shape).astype(f["dtype"], copy=False)


# -- the layout -------------------------------------------------------------------------------------
def _promoted(shape: tuple[int, ...], ndim: int) -> tuple[int, ...]:
    """A scalar among vectors counts as one entry."""
    return (1,) if shape == () and ndim == 1 else shape


def _region(shape: tuple[int, ...], merged: tuple[int, ...]) -> tuple[slice, ...]:
    """Where a source of `shape` sits inside the merged shape: the leading corner."""
    return tuple(slice(0, n) for n in _promoted(shape, len(merged)))


@dataclass
class _Field:
    name: str
    dtype: np.dtype
    shape: tuple[int, ...]
    sources: dict[str, tuple[int, ...]] = field(default_factory=dict)  # input label -> shape there


@dataclass
class _Input:
    root: Path
    label: str
    dataset: Dataset
    episodes: list[Episode]


def _layout(inputs: list[_Input]) -> dict[str, _Field]:
    """The merged fields, in order: timestep, t, t_recv, then first appearance, camera columns last."""
    seen: dict[str, list[tuple[str, np.dtype, tuple[int, ...]]]] = {}
    for inp in inputs:
        for ep in inp.episodes:
            for name, dt, shape in ep.schema.fields:
                seen.setdefault(name, []).append((inp.label, np.dtype(dt), tuple(shape)))
    order = [n for n in _ALWAYS if n in seen] + [n for n in seen if n not in _ALWAYS and not n.startswith("cam.")]
    order += sorted(n for n in seen if n.startswith("cam."))
    out: dict[str, _Field] = {}
    for name in order:
        uses = seen[name]
        shapes = {s for _, _, s in uses}
        if name.startswith("cam.") and shapes != {()}:
            raise MergeError(f"camera column '{name}' is not a scalar frame index in every input")
        try:
            dtype = np.result_type(*{d for _, d, _ in uses})
        except TypeError:
            raise MergeError(f"field '{name}' has dtypes that do not mix: "
                             + ", ".join(sorted({f"{lbl}: {d}" for lbl, d, _ in uses}))) from None
        if len(shapes) == 1:
            shape = next(iter(shapes))
        else:
            ndims = {len(s) for s in shapes}
            if max(ndims) <= 1:
                shape = (max(_promoted(s, 1)[0] for s in shapes),)
            elif len(ndims) == 1:
                shape = tuple(int(max(s[k] for s in shapes)) for k in range(ndims.pop()))
            else:
                raise MergeError(f"field '{name}' cannot be padded into one shape: "
                                 + ", ".join(sorted({f"{lbl}: {s}" for lbl, _, s in uses})))
        f = _Field(name, dtype, shape)
        for lbl, _, s in uses:
            f.sources.setdefault(lbl, s)
        out[name] = f
    return out


def _tree_has(child: Path, parent: Path) -> bool:
    try:
        child.relative_to(parent)
        return True
    except ValueError:
        return False


# -- writing ----------------------------------------------------------------------------------------
def _copy_checked(src: Path, dst: Path, want: dict[str, Any] | None) -> dict[str, Any]:
    """Copy a file byte for byte, hashing what was written; the copy must match what the source's
    episode.json recorded (it was verified, but it must not have changed since). Returns {bytes, sha256}."""
    h = hashlib.sha256()
    n = 0
    with open(src, "rb") as fin, open(dst, "xb") as fout:
        while block := fin.read(1 << 20):
            h.update(block)
            fout.write(block)
            n += len(block)
        fout.flush()
        os.fsync(fout.fileno())
    got = {"bytes": n, "sha256": h.hexdigest()}
    if want is not None and (want.get("bytes"), want.get("sha256")) != (n, got["sha256"]):
        raise MergeError(f"{src}: changed while it was being merged (its sha256 no longer matches episode.json)")
    return got


def _write_bytes(path: Path, data: bytes) -> dict[str, Any]:
    with open(path, "xb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    return {"bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}


def _merged_records(ep: Episode, fields: dict[str, _Field], dtype: np.dtype) -> tuple[np.ndarray, dict[str, Any]]:
    """The episode's steps in the merged layout, and its per-field {dtype, shape, mask}. An episode
    that is itself merged keeps its masks and original shapes (padding is never taken for data)."""
    src = ep.columns
    n = len(src)
    out = np.zeros(n, dtype)
    have = {name: (np.dtype(dt), tuple(s)) for name, dt, s in ep.schema.fields}
    before = (merge_info(ep) or {}).get("fields", {})
    info: dict[str, Any] = {}
    for name, f in fields.items():
        if name.startswith("cam."):
            out[name] = src[name] if name in have else -1
            continue
        m = np.zeros(f.shape, bool)
        dt_s: str | None = None
        shape_s: list[int] | None = None
        if name in have:
            dt, shape = have[name]
            region = _region(shape, f.shape)
            values = np.asarray(src[name]).reshape(n, *_promoted(shape, len(f.shape)))
            real = mask(ep, name).reshape(_promoted(shape, len(f.shape)))
            if region:
                out[name][(slice(None),) + region] = values
                m[region] = real
            else:
                out[name] = values
                m = real.copy()
            old = before.get(name)
            dt_s, shape_s = (old["dtype"], old["shape"]) if isinstance(old, dict) else (dt.str, list(shape))
        if name in _ALWAYS:
            continue
        info[name] = {"dtype": dt_s, "shape": shape_s, "mask": m.tolist()}
    return out, info


def _write_episode(out: Path, index: int, ep: Episode, inp: _Input, fields: dict[str, _Field],
                   schema_fields: list[tuple[str, str, tuple[int, ...]]], streams_all: list[str]) -> dict[str, Any]:
    partial = out / L.partial_dir_name(index)
    partial.mkdir()
    schema = StepSchema(schema_fields, ep.schema.observation_class, ep.schema.cameras)
    records, masks = _merged_records(ep, fields, schema.dtype)
    tag = embodiment_of(ep.meta)
    absent = [k for k in streams_all if k not in ep.streams]
    have_cams = {s["camera"] for s in ep.streams.values()}
    source: dict[str, Any] = {"dataset": os.path.abspath(inp.root), "name": inp.dataset.index.get("name"),
                              "index": ep.index, "dir": ep.path.name}
    if (earlier := merge_info(ep)) is not None:  # merging a merged dataset: where it came from first
        source["merged_from"] = earlier.get("source")
    merge = {"source": source,
             "embodiment": tag, "absent_streams": absent,
             "absent_cameras": sorted({k.rpartition(".")[0] for k in absent} - have_cams),
             "fields": masks, "merged_at": time.strftime("%Y-%m-%dT%H:%M:%S")}
    files: dict[str, Any] = {}
    layout = (json.dumps(schema.to_json(), indent=1) + "\n").encode()
    files[L.STEPS_SCHEMA] = _write_bytes(partial / L.STEPS_SCHEMA, layout)
    files[L.STEPS] = _write_bytes(partial / L.STEPS, records.tobytes())
    recorded = ep.meta.get("files", {})
    for name in recorded:
        if name in files:
            continue
        field = f"files[{name!r}]"  # read from the input's episode.json: confined on both sides
        files[name] = _copy_checked(ep.file(name, field), inside(partial, name, source=ep.path / L.EPISODE_META,
                                                                 field=field), recorded[name])
    rec_path = ep.path / L.RECORDING
    if rec_path.exists():  # what repair rebuilds episode.json from: keeps the merge facts too
        try:
            rec = json.loads(rec_path.read_bytes())
        except (OSError, ValueError):
            rec = None
        if isinstance(rec, dict):
            write_json_atomic(partial / L.RECORDING, {**rec, "index": index, "merge": merge})
    meta = copy.deepcopy(ep.meta)
    meta.update({"index": index, "dir": L.episode_dir_name(index), "merge": merge, "files": files})
    write_json_atomic(partial / L.EPISODE_META, meta)
    final = out / L.episode_dir_name(index)
    os.rename(partial, final)
    return meta


def _open_inputs(paths: list[Path]) -> list[_Input]:
    inputs: list[_Input] = []
    for p in paths:
        ds = Dataset(p)
        eps = list(ds)
        if not eps:
            raise MergeError(f"{p}: no finished episode to merge" + (
                f" (it has interrupted ones: run `rio datasets repair {p}`)" if ds.partials() else ""))
        inputs.append(_Input(p, str(p), ds, eps))
    return inputs


def merge_datasets(inputs: Sequence[str | Path], out: str | Path, *,
                   progress: MergeProgress | None = None) -> dict[str, Any]:
    """Merge native datasets into a new one at `out` (see the module docstring); returns a summary:
    {path, episodes, steps, fps, embodiments: {tag: episodes}, fields: {name: {dtype, shape, sources}},
    streams, sources}."""
    paths = [Path(p) for p in inputs]
    out = Path(out)
    if len(paths) < 2:
        raise MergeError(f"merge needs at least two datasets, got {len(paths)}")
    resolved = [p.resolve() for p in paths]
    for k, r in enumerate(resolved):
        if r in resolved[:k]:
            raise MergeError(f"{paths[k]}: given twice")
    out_r = out.resolve()
    for p, r in zip(paths, resolved, strict=True):
        if _tree_has(out_r, r) or _tree_has(r, out_r):
            raise MergeError(f"{out}: the output must not be inside an input dataset, nor hold one ({p})")
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise MergeError(f"{out} exists and is not an empty directory; merge writes a new dataset")

    # everything that can refuse the merge, before anything is written
    srcs = _open_inputs(paths)
    rates: dict[float, list[str]] = {}
    for inp in srcs:
        for ep in inp.episodes:
            rates.setdefault(ep.fps, [])
            if inp.label not in rates[ep.fps]:
                rates[ep.fps].append(inp.label)
    if len(rates) > 1:
        said = "; ".join(f"{fps:g} Hz: {', '.join(labels)}" for fps, labels in sorted(rates.items()))
        raise MergeError(f"the inputs were recorded at different rates ({said}); merge does not resample")
    fps = next(iter(rates))
    fields = _layout(srcs)
    schema_fields = [(f.name, f.dtype.str, f.shape) for f in fields.values()]
    streams_all = sorted({k for inp in srcs for ep in inp.episodes for k in ep.streams}
                         | {n[4:] for n in fields if n.startswith("cam.")})
    for k, inp in enumerate(srcs, 1):
        for ep in inp.episodes:
            try:
                ep.check()
            except DamagedEpisode as e:  # the same error, naming the episode and its files; no --allow-damaged here
                e.args = (f"{e.path}: damaged episode: {'; '.join(e.problems)} (merge refuses damaged inputs; "
                          f"`rio datasets info {inp.root}` lists them)",)
                raise
        if progress:
            left = len(inp.dataset.partials())
            progress(f"[{k}/{len(srcs)}] verified {inp.label}: {len(inp.episodes)} episodes, "
                     f"{sum(len(e) for e in inp.episodes)} steps"
                     + (f" ({left} interrupted episodes left out: `rio datasets repair` them first)" if left else ""))

    existed = out.exists()
    out.mkdir(parents=True, exist_ok=True)
    try:
        index = I.empty(out)
        mix: dict[str, int] = {}
        sources = []
        n = 0
        for k, inp in enumerate(srcs, 1):
            first = n
            tags: list[str] = []
            for ep in inp.episodes:
                meta = _write_episode(out, n, ep, inp, fields, schema_fields, streams_all)
                I.add_episode(index, meta)
                tag = meta["merge"]["embodiment"]["tag"]
                mix[tag] = mix.get(tag, 0) + 1
                if tag not in tags:
                    tags.append(tag)
                n += 1
            fsync_dir(out)
            sources.append({"path": os.path.abspath(inp.root), "name": inp.dataset.index.get("name"),
                            "episodes": [first, n - 1], "embodiments": tags})
            if progress:
                progress(f"[{k}/{len(srcs)}] merged {inp.label}: episodes {first}-{n - 1} ({', '.join(tags)})")
        for key in ("station", "embodiment"):
            values = {e.meta.get(key) for inp in srcs for e in inp.episodes}
            index[key] = values.pop() if len(values) == 1 else "mixed"
        layout = {f.name: {"dtype": f.dtype.str, "shape": list(f.shape),
                           "sources": {lbl: list(s) for lbl, s in f.sources.items()}}
                  for f in fields.values() if not f.name.startswith("cam.") and f.name not in _ALWAYS}
        index["merge"] = {"sources": sources, "embodiments": mix, "fields": layout, "streams": streams_all}
        I.save(out, index)
    except BaseException:
        if existed:
            for p in out.iterdir():
                if p.is_dir() and not p.is_symlink():
                    shutil.rmtree(p, ignore_errors=True)
                else:
                    p.unlink(missing_ok=True)
        else:
            shutil.rmtree(out, ignore_errors=True)
        raise
    return {"path": str(out), "episodes": n, "steps": index["total_steps"], "fps": fps, "embodiments": mix,
            "fields": layout, "streams": streams_all, "sources": sources}
