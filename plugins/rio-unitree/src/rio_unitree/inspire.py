"""`unitree.inspire`: one Inspire RH56 hand of a G1 (config `side`), through Unitree's Inspire DDS service.

On the robot, Unitree's Inspire service (its DFX_inspire_service, run on the G1's computer) owns both
hands' serial bus and speaks DDS: it takes `rt/inspire/cmd` (unitree_go `MotorCmds_`, 12 motors) and
publishes `rt/inspire/state` (`MotorStates_`, 12 motors) at 100 Hz. Motor order, as Unitree's service and
its xr_teleoperate number them: right hand 0-5, left hand 6-11, each hand pinky, ring, middle, index,
thumb bend, thumb rotation. Only `q` carries meaning: a normalised position, 1.0 fully open, 0.0 fully
closed (the service sends q * 1000 to the hand's angle register, and reads its angles back / 1000).

The joint model (rad) is the one Unitree's xr_teleoperate retargets onto before it normalises (its
inspire hand URDF's six driven joints, with the ranges its `normalize` uses): fingers 0 (open) .. 1.7
(closed), thumb bend 0 .. 0.5, thumb rotation -0.1 .. 1.3; q = (upper - rad) / (upper - lower). Joint
names are that URDF's: `R_pinky_proximal_joint`, ..., `R_thumb_proximal_pitch_joint` (bend),
`R_thumb_proximal_yaw_joint` (rotation), `L_...` on the left.

One message carries both hands, and the service applies all 12 positions of the newest one, so two
nodes (left and right) would undo each other's hand. Each node therefore writes whole messages in which
the motors it authors have `mode` 1 (the service ignores `mode`), and fills the other hand's motors
with the newest positions another writer authored (`mode` 1) on `rt/inspire/cmd`, or, until one has,
with where that hand is (holding it). So a left and a right node run side by side; a writer that marks
nothing (e.g. xr_teleoperate) is not followed: never run one beside these nodes.

The damping safety of every Unitree hand (`rio_unitree.hand.hand_parts`): the service offers no torque-free mode
(the hand's linear actuators hold wherever they are commanded), so this hand's "damping" is to stop where
it is: each own motor commanded to its measured position. Commands are clipped to the joint model's range.
There is no model of this hand in rio-sim, so `robot_description()` is None.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio.interfaces import HandNode

from .dds import INSPIRE_CMD, INSPIRE_STATE, Participant
from .hand import HandConfig, HandTopics, hand_parts
from .inspire_wire import MotorCmds, MotorStates
from .joint_table import pick

log = logging.getLogger("rio_unitree")

NUM_MOTORS = 12  # both hands
PER_HAND = 6
SIDES = ("left", "right")
FIRST_SLOT = {"right": 0, "left": 6}
_FINGERS = ("pinky_proximal", "ring_proximal", "middle_proximal", "index_proximal", "thumb_proximal_pitch",
            "thumb_proximal_yaw")
# (open, closed) in rad: xr_teleoperate's normalisation ranges (module docstring)
_RANGE = {"pinky_proximal": (0.0, 1.7), "ring_proximal": (0.0, 1.7), "middle_proximal": (0.0, 1.7),
          "index_proximal": (0.0, 1.7), "thumb_proximal_pitch": (0.0, 0.5), "thumb_proximal_yaw": (-0.1, 1.3)}


@dataclass(frozen=True)
class InspireJoint:
    name: str
    slot: int  # MotorCmds_ index
    lower: float  # rad, fully open (q = 1)
    upper: float  # rad, fully closed (q = 0)


def joints(side: str) -> tuple[InspireJoint, ...]:
    """One hand's joints in motor order."""
    if side not in SIDES:
        raise ValueError(f"an Inspire hand is 'left' or 'right', not {side!r}")
    prefix = "R" if side == "right" else "L"
    return tuple(InspireJoint(f"{prefix}_{f}_joint", FIRST_SLOT[side] + i, *_RANGE[f]) for i, f in enumerate(_FINGERS))


def joint_names(side: str) -> list[str]:
    return [j.name for j in joints(side)]


def lookup(side: str, names: list[str]) -> list[InspireJoint]:
    return pick(joints(side), names, f"Inspire {side} hand")


def to_wire(rad: Any, lower: Any, upper: Any) -> np.ndarray:
    """Joint angles (rad) -> the service's q (1 open .. 0 closed), clipped to [0, 1]."""
    lower, upper = np.asarray(lower, np.float64), np.asarray(upper, np.float64)
    return np.clip((upper - np.asarray(rad, np.float64)) / (upper - lower), 0.0, 1.0)


def from_wire(q: Any, lower: Any, upper: Any) -> np.ndarray:
    """The service's q -> joint angles (rad)."""
    lower, upper = np.asarray(lower, np.float64), np.asarray(upper, np.float64)
    return upper - np.asarray(q, np.float64) * (upper - lower)


class Inspire(HandNode):
    class Config(HandConfig):
        side: Literal["left", "right"] = Field("right", description="which Inspire hand")

    # -- setup --------------------------------------------------------------------------------------
    def default_joint_names(self) -> list[str]:
        return joint_names(self.config.side)

    def setup(self) -> None:
        super().setup()
        c = self.config
        self.joints = lookup(c.side, self.joint_list)
        self.slots = np.array([j.slot for j in self.joints], dtype=np.intp)
        self.lower = np.array([j.lower for j in self.joints])
        self.upper = np.array([j.upper for j in self.joints])
        first = FIRST_SLOT[c.side]
        self.own = np.zeros(NUM_MOTORS, bool)
        self.own[first:first + PER_HAND] = True
        self.others_q = np.full(NUM_MOTORS, np.nan)  # newest positions other writers authored
        hand_parts(self, f"the {c.side} Inspire hand on {c.interface} (DDS domain {c.domain_id})", INSPIRE_STATE)
        self.topics = HandTopics(INSPIRE_STATE, INSPIRE_CMD, self.decode_state,
                                 f"Unitree's Inspire service (rt/inspire/*) with the {c.side} Inspire hand",
                                 self.safety)

    # -- hardware -----------------------------------------------------------------------------------
    def open(self) -> None:
        self.topics.open(self.config, more=self._hear_commands)

    def _hear_commands(self, dds: Participant) -> None:
        self._cmds_in = dds.reader(INSPIRE_CMD, depth=32)

    def close(self) -> None:
        self.topics.close(self.damping if self.config.disable_on_close else None, self.config.rate_hz)

    def set_enabled(self, enabled: bool) -> None:
        if not enabled:
            self.topics.send(self.damping())

    def read_joints(self) -> dict[str, Any]:
        self.topics.poll()
        self.safety.watch()
        q, dq = self.joint_state(self.topics.state)
        return {"joint_pos": q, "joint_vel": dq}

    def write_joints(self, joint_pos: np.ndarray) -> None:
        self.topics.send(self.position(joint_pos, self.joint_state(self.topics.state)[0]))

    def write_disabled(self) -> None:
        self.topics.send(self.damping())

    def hardware_limits(self) -> tuple[list[float], list[float]]:
        return self.lower.tolist(), self.upper.tolist()

    def default_home(self) -> list[float]:
        return self.lower.tolist()  # open

    # -- the commands -----------------------------------------------------------------------------------
    def position(self, goal: np.ndarray, measured: np.ndarray) -> MotorCmds:
        """This node's joints to the goal (clipped to the joint model); its hand's others held."""
        cmd = self.damping()
        cmd.q[self.slots] = to_wire(np.clip(goal, self.lower, self.upper), self.lower, self.upper)
        return cmd

    def damping(self) -> MotorCmds:
        """Own hand held where it is (the service has no torque-free mode); the other hand as its writer
        last asked, else held where it is."""
        state = self.topics.state
        assert state is not None
        self._hear_others()
        cmd = MotorCmds.zeros(NUM_MOTORS)
        cmd.q[:] = state.q[:NUM_MOTORS]
        heard = ~self.own & np.isfinite(self.others_q)
        cmd.q[heard] = self.others_q[heard]
        cmd.mode[self.own] = 1
        return cmd

    # -- state --------------------------------------------------------------------------------------
    def decode_state(self, data: bytes) -> MotorStates | None:
        state = MotorStates.decode(data)
        if len(state.q) < NUM_MOTORS:
            log.warning("node '%s': %s with %d motors (the Inspire service sends %d): ignored", self.name,
                        INSPIRE_STATE, len(state.q), NUM_MOTORS)
            return None
        return state

    def joint_state(self, state: MotorStates) -> tuple[np.ndarray, np.ndarray]:
        q = from_wire(state.q[self.slots], self.lower, self.upper)
        return q, -state.dq[self.slots].astype(np.float64) * (self.upper - self.lower)

    def _hear_others(self) -> None:
        for data in self._cmds_in.take():
            try:
                msg = MotorCmds.decode(data)
            except ValueError:
                continue
            if len(msg.q) < NUM_MOTORS:
                continue
            theirs = ~self.own & (msg.mode[:NUM_MOTORS] != 0)
            self.others_q[theirs] = msg.q[:NUM_MOTORS][theirs]
