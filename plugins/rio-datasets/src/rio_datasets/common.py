"""What every exporter needs from a native dataset: the episodes asked for, one rate, the
low-dimensional columns under stable names, and the camera streams (one frame per step).

Two things an exporter writes differently from the native record, so a trainer can use its files as they are:

- actions: a native step holds the command sent just before its observation was read (the control loop
  sends, then reads: `env.step`), i.e. the command decided on the *previous* observation. Trainers pair an
  observation with the command issued after it, so exported `action[t]` is native `action[t + 1]` (the last
  step keeps its own: the robot holds its last command). `native_actions` undoes it on import, exactly
  when the export recorded the episode's first native action (`rio_attrs`: `first_action`);
- the environment state: the columns the episode's metadata names as such (`environment_state`, written by
  the recorder: a simulator's object poses), flattened into one `environment_state` vector per step with
  one name per element (`cube.x`, ..., `cube.qz`, ...), aligned with the observation (read at the same step);
- wrenches: a force/torque sensor of the wrench kind (`rio.interfaces.WrenchNode`) is recorded as two native
  columns, `meta.sensors.<name>.force` and `.torque` (the latest sample at each step); every format exports
  them as one field `wrench_<name>` of 6 values per step (fx, fy, fz N; tx, ty, tz N m, in the sensor's frame),
  beside the observation of the same step.
"""

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


#: The exported field of the environment state (`observation.environment_state` in LeRobot).
ENVIRONMENT_STATE = "environment_state"
#: The exported field of a wrench sensor: `wrench_<sensor name>`, and the names of its 6 elements.
WRENCH_PREFIX = "wrench_"
WRENCH_NAMES = ["fx", "fy", "fz", "tx", "ty", "tz"]
#: How exported actions pair with observations (`rio_attrs`), see the module docstring.
ACTIONS_AFTER_OBSERVATIONS = "action[t] is the command issued after observation[t]"


def lowdim(ep: Episode) -> dict[str, np.ndarray]:
    """{"action", "proprio", "proprio_eef", ..., "environment_state", "t"}: the numeric columns, (T, ...)
    each, actions paired with the observation they followed (`actions_after_observations`)."""
    out = ep.observation_columns()
    if "action" in ep.schema.names:
        out["action"] = actions_after_observations(ep.column("action"))
    env = environment_state(ep)
    if env is not None:
        out[ENVIRONMENT_STATE] = env[0]
    out.update(wrenches(ep))
    out["t"] = ep.column("t")
    return out


def wrenches(ep: Episode) -> dict[str, np.ndarray]:
    """{`wrench_<sensor>`: (T, 6) float64} for every sensor recorded with a 3-vector `force` and `torque`
    (the wrench kind's keys), sorted by sensor name."""
    names, out = set(ep.schema.names), {}
    for col in sorted(names):
        if not (col.startswith("meta.sensors.") and col.endswith(".force")):
            continue
        sensor = col[len("meta.sensors."):-len(".force")]
        torque = f"meta.sensors.{sensor}.torque"
        if torque not in names:
            continue
        f, t = ep.column(col), ep.column(torque)
        if f.shape[1:] == (3,) and t.shape[1:] == (3,):
            out[WRENCH_PREFIX + sensor] = np.concatenate([f, t], axis=1).astype(np.float64)
    return out


def actions_after_observations(action: np.ndarray) -> np.ndarray:
    """Native actions (each sent just before its step's observation) -> the command issued after each
    observation: row t takes row t + 1's, the last keeps its own."""
    out = np.array(action, copy=True)
    out[:-1] = action[1:]
    return out


def native_actions(exported: np.ndarray, first: Any = None) -> np.ndarray:
    """The inverse: row t takes exported row t - 1; row 0 is `first` (the native episode's first action,
    as `rio_attrs` stored it), else exported row 0 (a dataset from elsewhere: its first command)."""
    out = np.array(exported, copy=True)
    out[1:] = exported[:-1]
    if first is not None:
        out[0] = np.array([np.nan if v is None else v for v in first], dtype=np.float64)
    return out


def environment_layout(ep: Episode) -> dict[str, dict[str, Any]]:
    """{native column: {"names": element names, "shape": per-step shape}} of the episode's environment state."""
    spec = ep.meta.get(ENVIRONMENT_STATE) or {}
    shapes = {n: list(shape) for n, _, shape in ep.schema.fields}
    out = {}
    for col, names in spec.items():
        if col not in shapes:
            raise ExportError(f"episode {ep.index}: its environment state names column '{col}', "
                              "which it did not record")
        if int(np.prod(shapes[col])) != len(names):
            raise ExportError(f"episode {ep.index}: '{col}' holds {int(np.prod(shapes[col]))} values per step but "
                              f"{len(names)} names")
        out[col] = {"names": list(names), "shape": shapes[col]}
    return out


def environment_state(ep: Episode) -> tuple[np.ndarray, list[str]] | None:
    """The episode's environment state as one (T, E) float64 array and its E element names; None without."""
    layout = environment_layout(ep)
    if not layout:
        return None
    x = np.concatenate([ep.column(col).reshape(len(ep), -1).astype(np.float64) for col in layout], axis=1)
    return x, [n for spec in layout.values() for n in spec["names"]]


#: The elements of an end-effector pose (`proprio_eef`, an `eef_pose` action): m, then the quaternion w, x, y, z.
EEF_NAMES = ("x", "y", "z", "qw", "qx", "qy", "qz")


def episode_names(ep: Episode, field: str) -> list[str] | None:
    """The names the recording gave the elements of `field` ("action", "proprio", "proprio_joints",
    "environment_state", ...): the drivers' joint and gripper names (`action_names`, `observation_names`,
    written by the recorder), the environment state's object names; None if it named none."""
    meta = ep.meta
    if field == ENVIRONMENT_STATE:
        layout = environment_layout(ep)
        return [n for spec in layout.values() for n in spec["names"]] or None
    obs = meta.get("observation_names") if isinstance(meta.get("observation_names"), dict) else {}
    names = meta.get("action_names") if field == "action" else obs.get(field)
    if names is None and field == "proprio":  # recorded before observation names: proprio is laid out as the action
        names = meta.get("action_names")
    return [str(n) for n in names] if isinstance(names, list) and names else None


def element_names(eps: list[Episode], field: str, n: int) -> list[str]:
    """One name per element of an exported column of `n` values, for every format's `names`.

    Each episode's own names (`episode_names`) sit at the start of the column, where a merged episode's real
    values are (`rio datasets merge` pads after them); where the episodes name one element differently (a
    merged dataset of two robots) its name is theirs joined with `|` (`shoulder_pan|left_hip_pitch`). An
    element no episode names is `<field>_<i>` (an end-effector pose of 7: `x` ... `qz`)."""
    found: list[list[str]] = [[] for _ in range(n)]
    for ep in eps:
        names = episode_names(ep, field)
        if names is None or len(names) > n:
            continue
        for i, name in enumerate(names):
            if name not in found[i]:
                found[i].append(name)
    default = (list(EEF_NAMES) if field.endswith("eef") and n == len(EEF_NAMES)
               else list(WRENCH_NAMES) if field.startswith(WRENCH_PREFIX) and n == len(WRENCH_NAMES)
               else [f"{field}_{i}" for i in range(n)])
    out = ["|".join(f) if f else default[i] for i, f in enumerate(found)]
    if len(set(out)) != n:  # two elements named alike (a name repeated after padding): numbered instead
        return [f"{field}_{i}" for i in range(n)]
    return out


def robot_type(eps: list[Episode]) -> str | None:
    """The robot the episodes were recorded on: their `robot_type` (the station's arm driver, written by the
    recorder), distinct ones joined with `+` (a merged dataset); None when none recorded one."""
    types = list(dict.fromkeys(str(e.meta["robot_type"]) for e in eps if e.meta.get("robot_type")))
    return "+".join(types) or None


def empty_task_episodes(eps: list[Episode]) -> list[int]:
    """The episodes with a step recorded without an instruction (trainers of language-conditioned
    policies read an empty task there)."""
    return [e.index for e in eps if any(not s for s in e.instructions())]


def image_streams(ep: Episode, depth: bool = True) -> list[tuple[str, str]]:
    """(camera, kind) pairs, sorted, depth included only if asked."""
    return sorted((s["camera"], s["kind"]) for s in ep.streams.values() if depth or s["kind"] == "rgb")


def rio_attrs(ep: Episode) -> dict[str, Any]:
    """What a RIO import needs to rebuild the episode exactly (stored as an attribute / JSON)."""
    keys = ("fps", "instruction", "station", "embodiment", "robot_type", "action_names", "observation_names",
            "action_parts", "observation_class")
    out = {k: ep.meta.get(k) for k in keys if ep.meta.get(k) is not None}
    out["index"] = ep.index
    if "action" in ep.schema.names:
        first = ep.column("action")[0].reshape(-1)
        out["actions"] = ACTIONS_AFTER_OBSERVATIONS
        out["first_action"] = [float(v) if np.isfinite(v) else None for v in first]
    layout = environment_layout(ep)
    if layout:
        out[ENVIRONMENT_STATE] = layout
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
