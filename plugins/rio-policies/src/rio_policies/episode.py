"""Reading the actions of a recorded episode, for the replay policy, through the recording reader
(`rio.recording.Dataset` / `Episode`: RIO's native dataset layout). A plain `.npz` with `action`
[T, D] and optionally `t` [T] works too (episodes made by other tools)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def read_actions(path: str | Path, index: int = 0) -> tuple[np.ndarray, np.ndarray | None, float | None]:
    """(actions [T, D], times [T] or None, recorded fps or None); steps recorded without an action
    (NaN) are skipped. Times are when each action was to be reached (`Env.step`'s `t_cmd_target`,
    recorded as `meta.t_cmd_target`), on the clock of the episode's first observation (`t` = 0)."""
    p = Path(path)
    fps = None
    if p.suffix == ".npz":
        with np.load(p) as z:
            actions = np.asarray(z["action"], dtype=np.float64)
            times = np.asarray(z["t"], dtype=np.float64) if "t" in z.files else None
        fps = float(1.0 / np.median(np.diff(times))) if times is not None and len(times) > 1 else None
        times = None if times is None else times - times[0] + (1.0 / fps if fps else 0.0)
    else:
        from rio.recording import Dataset, Episode
        from rio.recording import paths as L

        ep = Episode(p) if (p / L.EPISODE_META).is_file() else Dataset(p).episode(index)
        actions = np.asarray(ep.column("action"), dtype=np.float64)
        t_obs, fps = np.asarray(ep.column("t"), dtype=np.float64), ep.fps
        names = ep.schema.names
        times = (np.asarray(ep.column("meta.t_cmd_target"), dtype=np.float64) if "meta.t_cmd_target" in names
                 else t_obs + 1.0 / fps) - t_obs[0]
    keep = np.isfinite(actions).all(axis=1)
    actions, times = actions[keep], (times[keep] if times is not None else None)
    if len(actions) == 0:
        raise ValueError(f"episode {path} has no actions")
    return actions, times, fps
