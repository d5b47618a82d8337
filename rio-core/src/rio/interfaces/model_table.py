"""A vendor's table of arm models: what differs per model and what a node of that vendor starts from.

Industrial arms come in families (xArm 5/6/7, UR3e..UR30, FR3/Panda, Gen3/Gen3 lite) that one driver
serves, picked by the station's `model`. The plugin keeps the facts in its `models.py`: a table of entries
(each with `name`, `joint_names`, `home` (rad) and `limits` ((lower, upper) rad per joint)), the defaults
a node starts from (its rate and step limits, which the vendor's controller dictates) and the highest rate
the controller takes. The driver names them once, and the arm kind (`ArmNode.models`) does the rest:

    MODELS = ModelTable(ARMS, description, default="xarm7", defaults=NODE_DEFAULTS, max_rate_hz=500.0)

    class XArm(ArmNode):
        models = MODELS

        class Config(NetworkDevice, ArmNode.Config):
            defaults = MODELS.defaults      # the kind's fields, the vendor's values (`rio.config.Config`)
            model: str = MODELS.field()     # one of the table's names; default and description from it

From the station's model's entry the kind takes `default_joint_names()`, `default_home()`,
`hardware_limits()` and `robot_description()` (`description(name, tcp_offset)` builds it); the station's
own `joint_names`, `home` and `joint_limits` still win.

An entry may also carry `reach` (m, the vendor's published reach) and `shoulder_height` (m, the shoulder
joint's axis above the base): the arm's default workspace box where no IK solver is installed (a plugin
installed without its kinematics extra, `ik_extra`, driving the controller's own Cartesian control).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Annotated, Any

from pydantic import AfterValidator, Field
from pydantic.fields import FieldInfo


class ModelTable:
    def __init__(self, models: Mapping[str, Any], describe: Callable[[str, Any], dict[str, Any] | None], *,
                 default: str, defaults: Mapping[str, Any] | None = None, max_rate_hz: float | None = None,
                 ik_extra: str | None = None):
        if default not in models:
            raise KeyError(f"default model '{default}' is not in the table ({', '.join(models)})")
        self.models, self.default = dict(models), default
        self._describe = describe
        self.defaults_given = dict(defaults or {})
        self.max_rate_hz = max_rate_hz
        #: The plugin's extra that installs the IK solver of these models ("rio-ufactory[ik]"): named by the
        #: errors of a node that needs it and finds it missing.
        self.ik_extra = ik_extra

    def entry(self, name: str) -> Any:
        """The entry of model `name` (a KeyError naming the known models otherwise)."""
        if name not in self.models:
            raise KeyError(f"unknown model '{name}'; known: {', '.join(self.models)}")
        return self.models[name]

    def describe(self, name: str, tcp_offset: Any = None) -> dict[str, Any] | None:
        """RIO's robot description of model `name` with the tool at `tcp_offset` (None: the flange)."""
        return self._describe(self.entry(name).name, tcp_offset)

    def reach(self, name: str) -> tuple[float, float] | None:
        """(published reach, shoulder height) of model `name` (m), or None where the entry has no `reach`."""
        entry = self.entry(name)
        reach = getattr(entry, "reach", None)
        if reach is None:
            return None
        return float(reach), float(getattr(entry, "shoulder_height", 0.0) or 0.0)

    @property
    def ik_install(self) -> str:
        """The command that installs the IK solver of these models."""
        return f"pip install '{self.ik_extra or 'rio-core[ik]'}'"

    @property
    def defaults(self) -> dict[str, Any]:
        """The config `defaults` of a node of this vendor: its own, `rate_hz` bounded by `max_rate_hz`."""
        out: dict[str, Any] = dict(self.defaults_given)
        if self.max_rate_hz is not None:
            rate = out.get("rate_hz")
            out["rate_hz"] = Field(le=self.max_rate_hz) if rate is None else Field(rate, le=self.max_rate_hz)
        return out

    def field(self) -> Any:
        """The `model` field: one of the table's names (checked when the config is validated), the table's
        default, a description listing them."""
        names = tuple(self.models)

        def known(name: str) -> str:
            if name not in self.models:
                raise ValueError(f"unknown model '{name}'; known: {', '.join(names)}")
            return name

        info = FieldInfo.from_annotation(Annotated[str, AfterValidator(known)])  # type: ignore[arg-type]
        return FieldInfo.merge_field_infos(info, default=self.default, description=f"which model: {', '.join(names)}",
                                           json_schema_extra={"enum": list(names)})
