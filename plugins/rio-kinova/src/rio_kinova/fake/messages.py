"""Stand-ins for the few kortex protobuf messages the driver builds and reads, with kortex's field
names, enum names and values (`Base_pb2`, `BaseCyclic_pb2`, `Common_pb2`), so the driver code is the
same on the fake as on a real base. A message takes any field; repeated fields have `.add()` like
protobuf's; nested messages are made on first access. No wire format: nothing is serialized.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any


class Repeated(list):
    def add(self, **fields: Any) -> Message:
        m = Message(**fields)
        self.append(m)
        return m


#: The repeated fields of the messages used (kortex's names).
REPEATED = frozenset({"joint_speeds", "actuators", "finger", "motor"})


class Message:
    def __init__(self, **fields: Any):
        for k, v in fields.items():
            setattr(self, k, v)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        m: Any = Repeated() if name in REPEATED else Message()
        object.__setattr__(self, name, m)
        return m

    def __repr__(self) -> str:
        return f"{type(self).__name__}({vars(self)})"


def _message(name: str) -> type[Message]:
    return type(name, (Message,), {})


class Enum:
    """An enum wrapper with protobuf's `Name(value)` / `Value(name)`."""

    def __init__(self, **values: int):
        self.values = values

    def Name(self, value: int) -> str:  # noqa: N802 (protobuf's name)
        return next((k for k, v in self.values.items() if v == value), str(value))

    def Value(self, name: str) -> int:  # noqa: N802
        return self.values[name]


ArmState = Enum(ARMSTATE_UNSPECIFIED=0, ARMSTATE_BASE_INITIALIZATION=1, ARMSTATE_IDLE=2,
                ARMSTATE_INITIALIZATION=3, ARMSTATE_IN_FAULT=4, ARMSTATE_MAINTENANCE=5,
                ARMSTATE_SERVOING_LOW_LEVEL=6, ARMSTATE_SERVOING_READY=7, ARMSTATE_SERVOING_PLAYING_SEQUENCE=8,
                ARMSTATE_SERVOING_MANUALLY_CONTROLLED=9, ARMSTATE_RESERVED=255)
ServoingMode = Enum(UNSPECIFIED_SERVOING_MODE=0, SINGLE_LEVEL_SERVOING=2, LOW_LEVEL_SERVOING=3, BYPASS_SERVOING=4)
GripperMode = Enum(UNSPECIFIED_GRIPPER_MODE=0, GRIPPER_FORCE=1, GRIPPER_SPEED=2, GRIPPER_POSITION=3)
ActionEvent = Enum(UNSPECIFIED_ACTION_EVENT=0, ACTION_END=1, ACTION_ABORT=2, ACTION_PAUSE=3, ACTION_START=4,
                   ACTION_FEEDBACK=5)
CartesianReferenceFrame = Enum(CARTESIAN_REFERENCE_FRAME_UNSPECIFIED=0, CARTESIAN_REFERENCE_FRAME_MIXED=1,
                               CARTESIAN_REFERENCE_FRAME_TOOL=2, CARTESIAN_REFERENCE_FRAME_BASE=3)
#: A stand-in sub-error for an emergency stop (kortex's real names are what the driver prints).
SubErrorCodes = Enum(SUB_ERROR_NONE=0, EMERGENCY_STOP_ACTIVATED=1000, JOINT_FAULT=1001)

Common_pb2 = SimpleNamespace(ArmState=ArmState, NotificationOptions=_message("NotificationOptions"),
                             **ArmState.values)
Base_pb2 = SimpleNamespace(
    JointSpeeds=_message("JointSpeeds"),
    TwistCommand=_message("TwistCommand"),
    ServoingModeInformation=_message("ServoingModeInformation"),
    GripperCommand=_message("GripperCommand"),
    GripperRequest=_message("GripperRequest"),
    Gripper=_message("Gripper"),
    ServoingMode=ServoingMode, GripperMode=GripperMode, ActionEvent=ActionEvent,
    **ServoingMode.values, **GripperMode.values, **ActionEvent.values, **CartesianReferenceFrame.values)
BaseCyclic_pb2 = SimpleNamespace(Command=_message("Command"), Feedback=_message("Feedback"))
Errors_pb2 = SimpleNamespace(SubErrorCodes=SubErrorCodes)

# the enum values at module level too, as kortex's generated modules have them
globals().update({**ArmState.values, **ServoingMode.values, **GripperMode.values, **ActionEvent.values,
                  **CartesianReferenceFrame.values})
