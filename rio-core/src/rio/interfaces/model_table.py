"""An arm whose joints, home, limits and robot model come from its vendor plugin's model table.

Industrial arms come in families (xArm 5/6/7, UR3e..UR30, FR3/Panda, Gen3/Gen3 lite) that one driver
serves, picked by the station's `model` field. Each plugin keeps a table of what differs per model and a
function building RIO's robot description from an entry; this mixin turns the table into the
`JointNode`/`ArmNode` hooks, so a vendor driver names its table and writes only hardware logic:

    class XArm(ControllerLink, ModelTableArm, ArmNode):
        lookup_model = staticmethod(get_arm)        # model name -> entry
        describe_model = staticmethod(description)  # (model name, tcp_offset) -> robot description

An entry has `name`, `joint_names`, `home` (rad) and `limits` ((lower, upper) rad per joint); the
driver's config has `model` and `tcp_offset`. The station's own `joint_names`, `home` and
`joint_limits` still win (the kind applies them over these defaults).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np

from rio.runtime.node import remote


class ModelTableArm:
    """Mixed in ahead of `ArmNode`; see the module docstring."""

    config: Any
    #: The plugin's table lookup: model name -> entry (raises naming the known models).
    lookup_model: ClassVar[Callable[[str], Any]]
    #: The plugin's robot description of a model: (model name, tcp_offset or None) -> description.
    describe_model: ClassVar[Callable[[str, Any], dict[str, Any] | None]]

    @property
    def model_entry(self) -> Any:
        """This node's table entry (from the config, so it is there before `setup()` finishes)."""
        return type(self).lookup_model(self.config.model)

    def default_joint_names(self) -> list[str]:
        return list(self.model_entry.joint_names)

    def default_home(self) -> list[float]:
        return [float(v) for v in self.model_entry.home]

    def hardware_limits(self) -> tuple[np.ndarray, np.ndarray]:
        lim = np.asarray(self.model_entry.limits, dtype=np.float64)
        return lim[:, 0], lim[:, 1]

    @remote
    def robot_description(self) -> dict[str, Any] | None:
        return type(self).describe_model(self.model_entry.name, getattr(self.config, "tcp_offset", None))
