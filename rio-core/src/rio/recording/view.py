"""One recorded episode in rerun's viewer (`rio datasets view`): camera streams, per-joint plots of state
and action, gripper, and the end effector's trajectory with its current pose.

    view_episode("datasets/pick", 3)                   # spawns rerun's viewer (headless: saves an .rrd)
    view_episode("datasets/pick", 3, save="ep3.rrd")   # writes ep3.rrd: `rerun ep3.rrd` opens it

What goes where (entity paths):

    cameras/<camera>/rgb, cameras/<camera>/depth   every recorded frame once, at its capture time
    joints/<name>/state, joints/<name>/action      `obs.proprio` and `action`, one plot per joint; names
                                                   from the episode's `action_names` (else 0, 1, ...)
    gripper/<field>                                gripper observation fields (gripper_width, ...)
    state/<field>/<i>                              other numeric observation fields (proprio_joints, ...)
    world/<field>/trajectory, world/<field>/pose   end-effector fields (proprio_eef, arm1_proprio_eef, ...):
                                                   the whole path as a line strip, the pose at each step

Timelines: "time" (seconds from the episode's start, the recorded timestamps) and "step" (0, 1, ...). Frames are
decoded and logged one at a time, so an episode of any length fits in memory; rgb frames are stored
JPEG-compressed. The episode is verified first: a damaged one is refused (DamagedEpisode) unless the
Dataset was opened with `allow_damaged=True`. The logging itself is `rio.viz.RerunViz`, shared
with `rio teleop --viz`.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from rio.errors import RioError
from rio.recording.dataset import Dataset, DatasetError, Episode

#: Stored JPEG quality of rgb frames (raw frames would make an .rrd about as big as the decoded video).
JPEG_QUALITY = 90
#: Length of the arrows drawn at the end effector's pose, in meters.
AXIS_LENGTH_M = 0.05
#: Progress is reported every this many steps.
PROGRESS_EVERY = 25

Progress = Callable[[int, int, str], None]


class RerunMissing(RioError):
    def __init__(self) -> None:
        from rio.viz import INSTALL_HINT

        super().__init__(f"viewing a dataset needs rerun: {INSTALL_HINT} (or pip install rio-sim[viz])")


def default_save_path(dataset: Dataset, episode: Episode) -> Path:
    """Where a headless view is saved: `<dataset name>-episode_<K>.rrd` in the current directory."""
    name = re.sub(r"[^A-Za-z0-9_.-]+", "_", dataset.root.resolve().name) or "dataset"
    return Path(f"{name}-episode_{episode.index:06d}.rrd")


def _is_pose(field: str) -> bool:
    return field == "eef" or field.endswith("_eef")


def _names(n: int, names: list[str] | None) -> list[str]:
    return [str(x) for x in names] if names and len(names) == n else [str(i) for i in range(n)]


def _title(path: str) -> str:
    """A plot's title from its entity path: joints/arm.0 -> arm.0, joints/3 -> joint 3, gripper -> gripper."""
    last = path.split("/", 1)[-1]
    return f"joint {last}" if last.isdigit() else last


class _Plan:
    """What of an episode goes to which entity path (see the module docstring)."""

    def __init__(self, rr: Any, ep: Episode):
        esc = getattr(rr, "escape_entity_path_part", lambda s: s)
        cols = ep.columns
        self.steps = len(cols)
        obs = {n[4:]: np.asarray(cols[n], np.float64).reshape(self.steps, -1)
               for n in ep.schema.names if n.startswith("obs.")}
        self.action = np.asarray(cols["action"], np.float64).reshape(self.steps, -1) \
            if "action" in ep.schema.names else None
        state = obs.get("proprio")
        names = ep.meta.get("action_names")
        self.series: list[tuple[str, np.ndarray]] = []  # (entity path, (T,) values)
        self.joint_views: list[str] = []  # one plot each
        paired = state is not None and self.action is not None and state.shape[1] == self.action.shape[1]
        if paired:
            assert state is not None and self.action is not None
            for i, name in enumerate(_names(state.shape[1], names)):
                self.joint_views.append(f"joints/{esc(name)}")
                self.series += [(f"joints/{esc(name)}/state", state[:, i]),
                                (f"joints/{esc(name)}/action", self.action[:, i])]
        else:  # different layouts: state and action each in their own plots
            for label, v in (("state", state), ("action", self.action)):
                if v is not None:
                    self.joint_views.append(f"joints/{label}")
                    self.series += [(f"joints/{label}/{esc(name)}", v[:, i])
                                    for i, name in enumerate(_names(v.shape[1], names if label == "action" else None))]
        self.poses: list[tuple[str, np.ndarray]] = []  # (field, (T, 7) or (T, 3))
        self.other_views: list[str] = []
        for field, v in obs.items():
            if field == "proprio":
                continue
            if _is_pose(field) and v.shape[1] >= 3:
                self.poses.append((field, v))
            elif "gripper" in field and v.shape[1] == 1:
                self.series.append((f"gripper/{esc(field)}", v[:, 0]))
                if "gripper" not in self.other_views:
                    self.other_views.append("gripper")
            else:
                self.other_views.append(f"state/{esc(field)}")
                self.series += [(f"state/{esc(field)}/{i}", v[:, i]) for i in range(v.shape[1])]
        self.streams = sorted(ep.streams)  # "<camera>.<kind>"

    def blueprint(self, ep: Episode) -> Any:
        import rerun.blueprint as rrb

        cams = [rrb.Spatial2DView(origin=f"cameras/{ep.streams[k]['camera']}/{ep.streams[k]['kind']}", name=k)
                for k in self.streams]
        left = [*cams, *([rrb.Spatial3DView(origin="world", name="end effector")] if self.poses else [])]
        plots = [rrb.TimeSeriesView(origin=p, name=_title(p)) for p in self.joint_views + self.other_views]
        panes = [v for v in (rrb.Grid(*left) if left else None, rrb.Grid(*plots) if plots else None) if v is not None]
        return rrb.Blueprint(rrb.Horizontal(*panes) if len(panes) > 1 else panes[0]) if panes else None


def _frames(ep: Episode, key: str, warn: Callable[[str], None]) -> Iterator[tuple[float, int, np.ndarray]]:
    """(capture time, first step that saw it, frame) of one stream, decoded one at a time. A stream that
    stops decoding early (damaged, used with allow_damaged) ends there with a warning."""
    info = ep.streams[key]
    try:
        times = ep.frame_times(info["camera"], info["kind"])
    except OSError as e:  # its frames file missing (damaged, used with allow_damaged)
        if not ep.allow_damaged:
            raise
        warn(f"{key}: left out ({e.strerror}: {e.filename})")
        return
    frames = ep.frames(info["camera"], info["kind"])
    for k, rec in enumerate(times):
        try:
            frame = next(frames)
        except StopIteration:
            warn(f"{key}: {k} of {len(times)} frames could be decoded")
            return
        except Exception as e:  # a damaged video read anyway: show what could be decoded
            if not ep.allow_damaged:
                raise
            warn(f"{key}: stops at frame {k} of {len(times)} ({type(e).__name__}: {e})")
            return
        yield float(rec["t"]), int(rec["step"]), frame


def view_episode(dataset: Dataset | str | Path, episode: int | None = None, *, save: str | Path | None = None,
                 progress: Progress | None = None, warn: Callable[[str], None] = print) -> dict[str, Any]:
    """Log episode `episode` (its index; None: the first) of `dataset` to rerun: its viewer is spawned,
    or with `save` (or headless: `default_save_path`) an .rrd is written. Returns what was logged:
    {"episode", "steps", "frames": {stream: count}, "where": "viewer" or the .rrd path, "headless"}."""
    from rio.viz import RerunViz, headless, load_rerun

    ds = dataset if isinstance(dataset, Dataset) else Dataset(dataset)
    if episode is None:
        if not ds.episodes:
            raise DatasetError(f"{ds.root}: no episodes")
        episode = int(ds.episodes[0]["index"])
    ep = ds.episode(episode)
    rr = load_rerun()
    if rr is None:
        raise RerunMissing()
    ep.check()  # a damaged episode is refused before anything is written or spawned
    try:
        plan = _Plan(rr, ep)
    except OSError as e:  # steps.bin missing (damaged, used with allow_damaged)
        raise DatasetError(f"{ep.path}: cannot read its steps ({e.strerror}: {e.filename})") from None
    was_headless = save is None and headless()
    if was_headless:
        save = default_save_path(ds, ep)
    if save is not None:
        save = Path(save)
        if save.is_dir():
            raise RioError(f"--save {save}: is a directory, not a file")
        save.parent.mkdir(parents=True, exist_ok=True)
    t = np.asarray(ep.columns["t"], np.float64)
    t0 = float(ep.meta.get("t_start", t[0] if len(t) else 0.0))

    viz = RerunViz(rr, f"rio_dataset_{ds.root.resolve().name}", None if save is None else str(save))
    counts = dict.fromkeys(plan.streams, 0)
    depth_meter = {k: 1.0 / float(ep.streams[k].get("depth_unit_m", 0.001)) for k in plan.streams
                   if ep.streams[k]["kind"] == "depth"}
    streams = {k: _frames(ep, k, warn) for k in plan.streams}
    pending: dict[str, tuple[float, int, np.ndarray] | None] = dict.fromkeys(streams)

    def frames_up_to(step: float) -> None:
        """Log every frame first seen at or before `step`, each at its own capture time."""
        for key, it in streams.items():
            while (item := pending[key]) is not None and item[1] <= step:
                ft, fstep, frame = item
                viz.time(ft - t0, max(fstep, 0))
                path = "cameras/" + key.replace(".", "/", 1)
                if key in depth_meter:
                    viz.depth(path, frame, meter=depth_meter[key])
                else:
                    viz.image(path, frame, JPEG_QUALITY)
                counts[key] += 1
                pending[key] = next(it, None)

    try:
        pending.update((k, next(it, None)) for k, it in streams.items())
        if (bp := plan.blueprint(ep)) is not None:
            rr.send_blueprint(bp)
        if plan.poses:
            viz.static("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP)
        for field, v in plan.poses:
            ok = np.isfinite(v[:, :3]).all(axis=1)
            viz.static(f"world/{field}/trajectory", rr.LineStrips3D([v[ok, :3]]))
            viz.axes(f"world/{field}/pose", AXIS_LENGTH_M)
        for i in range(plan.steps):
            frames_up_to(i)
            viz.time(float(t[i]) - t0, i)
            for path, values in plan.series:
                viz.scalar(path, values[i])
            for field, v in plan.poses:
                if np.isfinite(v[i]).all():
                    viz.pose(f"world/{field}/pose", v[i])
            if progress is not None and (i % PROGRESS_EVERY == 0 or i == plan.steps - 1):
                progress(i + 1, plan.steps, f"episode {ep.index}")
        frames_up_to(float("inf"))  # none in a normal recording: a frame is logged with the step that saw it
    finally:
        viz.close()
    return {"episode": ep.index, "steps": plan.steps, "frames": counts,
            "where": viz.where, "headless": was_headless}
