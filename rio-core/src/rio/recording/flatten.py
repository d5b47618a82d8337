"""Step <-> fixed-size binary record.

A `Step` holds a morphology observation (`SingleArmObs`, ...), an action and a meta dict. Its
numeric parts become named columns of one numpy structured dtype, fixed by the first step of an
episode, so every step is one `tobytes()` appended to `steps.bin` (cheap in the control loop, and a
crash leaves whole records). Column names:

    timestep, t (the observation time, `meta["t_obs"]` or the time of `add`), t_recv (time of `add`)
    obs.<field>        every numeric Observation field but `cameras` (proprio, proprio_eef, ...)
    action             the flat action vector (NaN where a step had none)
    meta.<key>         numeric meta values; nested dicts flattened: meta.timestamps.arm
    cam.<name>.<kind>  index of the camera frame (rgb/depth) this step saw, -1 for none

Values keep their dtype (float64 stays float64), so state read back is bit-exact. Strings (the
instruction, a station name) do not fit a fixed record: the recorder logs their changes in
events.jsonl instead.
"""

from __future__ import annotations

import dataclasses
import importlib
from typing import Any

import numpy as np

from rio.schema import Camera, Observation, Step

CAMERA_KINDS = ("rgb", "depth")


class SchemaError(ValueError):
    """A step does not fit the episode's record layout (a field changed shape or type)."""


def _is_numeric(v: Any) -> bool:
    if isinstance(v, (bool, int, float, np.number, np.bool_)):
        return True
    return isinstance(v, np.ndarray) and v.dtype.kind in "biuf" and v.size <= 4096


def _numeric_dtype(v: Any) -> np.dtype:
    if isinstance(v, (bool, np.bool_)):
        return np.dtype(np.bool_)
    if isinstance(v, int) and not isinstance(v, np.integer):
        return np.dtype(np.int64)
    if isinstance(v, float):
        return np.dtype(np.float64)
    return np.asarray(v).dtype


def flat_meta(meta: dict | None, prefix: str = "meta") -> tuple[dict[str, Any], dict[str, Any]]:
    """Split meta into (numeric columns, everything else), flattening nested dicts with dots."""
    numeric: dict[str, Any] = {}
    other: dict[str, Any] = {}
    for k, v in (meta or {}).items():
        name = f"{prefix}.{k}"
        if isinstance(v, dict):
            n, o = flat_meta(v, name)
            numeric.update(n)
            other.update(o)
        elif v is None:
            continue
        elif _is_numeric(v):
            numeric[name] = v
        else:
            other[name] = v
    return numeric, other


def observation_fields(obs: Observation) -> dict[str, Any]:
    """Numeric observation fields by column name (`obs.<field>`), None fields left out."""
    out = {}
    for f in dataclasses.fields(obs):
        if f.name == "cameras":
            continue
        v = getattr(obs, f.name)
        if v is not None and _is_numeric(v):
            out[f"obs.{f.name}"] = v
    return out


def class_path(cls: type) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"


def load_class(path: str, base: type | None = None) -> type:
    """'module:Qualified.Name' -> the class. With `base`, anything but a subclass of it is one ConfigError:
    the path comes from a dataset's steps.json, and what it names is then called with the step's fields
    (`os:system` must not be)."""
    from rio.errors import ConfigError

    mod, _, name = path.partition(":")
    try:
        obj: Any = importlib.import_module(mod)
        for part in name.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError, ValueError) as e:
        raise ConfigError(f"class '{path}' cannot be loaded ({type(e).__name__}: {e})") from None
    if base is not None and not (isinstance(obj, type) and issubclass(obj, base)):
        raise ConfigError(f"'{path}' is not {base.__name__} or a subclass of it; refused")
    return obj


class StepSchema:
    """The record layout of one episode's steps.bin (see the module docstring)."""

    def __init__(self, fields: list[tuple[str, str, tuple[int, ...]]], observation_class: str,
                 cameras: dict[str, list[str]]):
        self.fields = [(n, np.dtype(d).newbyteorder("<").str, tuple(s)) for n, d, s in fields]
        self.observation_class = observation_class
        #: camera name -> kinds present ("rgb", "depth")
        self.cameras = cameras
        self.dtype = np.dtype([(n, d, s) for n, d, s in self.fields])
        self.names = [n for n, _, _ in self.fields]

    # -- building -----------------------------------------------------------------------------------
    @classmethod
    def from_step(cls, step: Step, action_dim: int | None = None) -> StepSchema:
        fields: list[tuple[str, str, tuple[int, ...]]] = [
            ("timestep", "<i8", ()), ("t", "<f8", ()), ("t_recv", "<f8", ())]
        for name, v in observation_fields(step.observation).items():
            a = np.asarray(v)
            fields.append((name, _numeric_dtype(v).str, a.shape))
        if step.action is not None:
            a = np.asarray(step.action)
            dt = a.dtype if a.dtype.kind == "f" else np.dtype(np.float64)
            fields.append(("action", dt.str, a.shape))
        elif action_dim is not None:
            fields.append(("action", "<f8", (int(action_dim),)))
        numeric, _ = flat_meta(step.meta)
        for name, v in numeric.items():
            fields.append((name, _numeric_dtype(v).str, np.asarray(v).shape))
        cameras: dict[str, list[str]] = {}
        for cam, c in (step.observation.cameras or {}).items():
            kinds = [k for k in CAMERA_KINDS if k in c.kinds()]  # not c.rgb: that would copy the pixels out
            if kinds:
                cameras[cam] = kinds
                fields.extend((f"cam.{cam}.{k}", "<i4", ()) for k in kinds)
        return cls(fields, class_path(type(step.observation)), cameras)

    def to_json(self) -> dict[str, Any]:
        return {"fields": [[n, d, list(s)] for n, d, s in self.fields], "itemsize": self.dtype.itemsize,
                "observation_class": self.observation_class, "cameras": self.cameras}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> StepSchema:
        return cls([(n, dt, tuple(s)) for n, dt, s in d["fields"]], d["observation_class"], d.get("cameras", {}))

    # -- one step -> one record ---------------------------------------------------------------------
    def record(self, step: Step, t: float, t_recv: float, frames: dict[str, int]) -> np.ndarray:
        """One record; `frames` maps 'cam.<name>.<kind>' to the frame index this step saw."""
        rec = np.zeros((), dtype=self.dtype)
        values: dict[str, Any] = observation_fields(step.observation)
        values.update(flat_meta(step.meta)[0])
        values.update(frames)
        values["timestep"] = -1 if step.timestep is None else int(step.timestep)
        values["t"], values["t_recv"] = t, t_recv
        if step.action is not None:
            values["action"] = step.action
        for name, _, shape in self.fields:
            v = values.get(name)
            if v is None:
                kind = self.dtype[name].base.kind
                if kind == "f":
                    rec[name] = np.nan
                elif name.startswith("cam."):
                    rec[name] = -1
                continue
            a = np.asarray(v)
            if a.shape != shape:
                raise SchemaError(f"step {values['timestep']}: '{name}' has shape {a.shape}, the episode "
                                  f"started with {shape}")
            rec[name] = a
        return rec

    def unknown_fields(self, step: Step) -> list[str]:
        """Numeric fields of `step` this layout has no column for (reported once, not stored)."""
        have = set(self.names)
        names = list(observation_fields(step.observation)) + list(flat_meta(step.meta)[0])
        if step.action is not None:
            names.append("action")
        return [n for n in names if n not in have]

    # -- records -> steps ---------------------------------------------------------------------------
    def observation(self, rec: np.void | np.ndarray, cameras: dict[str, Camera] | None = None) -> Observation:
        cls = load_class(self.observation_class, Observation)
        kw: dict[str, Any] = {}
        names = {f.name for f in dataclasses.fields(cls)}
        for name in self.names:
            if name.startswith("obs."):
                field = name[4:]
                if field in names:
                    v = np.array(rec[name])
                    kw[field] = v.item() if v.shape == () else v
        kw.setdefault("proprio", np.zeros(0))
        return cls(cameras=cameras or {}, **kw)

    def meta(self, rec: np.void | np.ndarray) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for name in self.names:
            if not name.startswith("meta."):
                continue
            parts = name.split(".")[1:]
            d = out
            for p in parts[:-1]:
                d = d.setdefault(p, {})
            v = np.array(rec[name])
            d[parts[-1]] = v.item() if v.shape == () else v
        return out
