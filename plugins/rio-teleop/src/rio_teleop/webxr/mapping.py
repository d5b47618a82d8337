"""From controller poses to the teleop contract (twist, gripper, buttons), with a clutch.

The robot follows the controller only while the clutch is held. Pressing it takes an *anchor*: the
controller pose at that moment. While held, the controller's motion relative to the anchor (turned
into the robot's base frame, scaled) is what the robot does:

- `mapping = "pose"` (absolute wrist target): the tool's target is where it was when the clutch went
  down plus the controller's displacement since. The target goes out through the twist channel (the
  contract every teleop device speaks): the node publishes the twist that closes the gap between the
  target and what it has already sent (integrated exactly as `rio.teleop.twist.DevicePoll` integrates
  it: trapezoids over the samples' timestamps), at most `max_speed`, so the controller loop lands the
  tool on the target without this node knowing where the tool is.
- `mapping = "twist"` (rate control, a joystick in the air): the displacement from the anchor, past a
  dead band, sets the tool's velocity.

Releasing the clutch freezes the target: moving the controller then moves nothing; pressing it again
takes a new anchor and the tool continues from where it is. The watchdog: no message for `stale_s`,
or no page connected, releases the clutch, drops whatever of the target was not yet sent (the arm
stops where it is rather than finishing a move nobody is watching) and publishes zero twist; the
clutch then has to be released and pressed again. The gripper holds its last command meanwhile.

WebXR reference spaces are y up, -z forward, x right; the robot's base frame is x forward, y left,
z up. `yaw_deg` turns the mapping about z for an operator who does not face the robot's x axis
(`xr_to_robot`: the one rotation both mappers use).

`HandMapper` is `teleop.webxr_hands`' side: no clutch and no twist; it turns the page's `hands`
messages into the hand tracker contract (rio.interfaces.teleop: wrist_pose, hand_keypoints, tracked,
gripper from the driving hand's pinch) in the reference space turned to the robot's axes, and says
a hand is tracked only while its stream is fresh.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rio.control.rotations import (
    matrix_to_quat,
    quat_conj,
    quat_mul,
    quat_normalize,
    quat_to_rotvec,
    rotvec_to_quat,
)
from rio.interfaces.teleop import hand_tracker_sample, pinch_opening

#: WebXR (x right, y up, z back) -> robot base (x forward, y left, z up)
XR_TO_ROBOT = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
ID_Q = np.array([1.0, 0.0, 0.0, 0.0])
SETTLED_M, SETTLED_RAD = 1e-4, 1e-3


def xr_to_robot(yaw_deg: float = 0.0) -> np.ndarray:
    """The rotation from a WebXR reference space to the robot's base axes, turned by `yaw_deg` about z."""
    yaw = np.deg2rad(yaw_deg)
    rz = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    return rz @ XR_TO_ROBOT


def _clip(v: np.ndarray, limit: float) -> np.ndarray:
    n = float(np.linalg.norm(v))
    return v * (limit / n) if n > limit else v


class ClutchMapper:
    def __init__(self, *, mapping: str = "pose", scale: float = 1.0, rot_scale: float = 1.0, yaw_deg: float = 0.0,
                 max_speed: float = 0.15, max_rot_speed: float = 1.0, gain: float = 20.0, twist_gain: float = 2.0,
                 dead_band_m: float = 0.01, stale_s: float = 0.25, buttons: int = 2):
        if mapping not in ("pose", "twist"):
            raise ValueError(f"mapping must be 'pose' or 'twist', not {mapping!r}")
        self.R = xr_to_robot(yaw_deg)
        self.mapping, self.scale, self.rot_scale = mapping, float(scale), float(rot_scale)
        self.max_speed, self.max_rot_speed = float(max_speed), float(max_rot_speed)
        self.gain, self.twist_gain, self.dead_band = float(gain), float(twist_gain), float(dead_band_m)
        self.stale_s, self.n_buttons = float(stale_s), int(buttons)
        self.connected = False
        self.t_msg = -np.inf          # arrival time of the newest accepted input message
        self.pose: tuple[np.ndarray, np.ndarray] | None = None  # newest controller pose (p, q w-first)
        self.clutch_in = False        # the page's clutch button, as last sent
        self.engaged = False          # following (clutch pressed with a pose, stream fresh)
        self.need_release = True      # after a drop-out: the clutch must go up before it engages again
        self.anchor: tuple[np.ndarray, np.ndarray] | None = None
        self.base_p, self.base_q = np.zeros(3), ID_Q.copy()   # target when the clutch went down
        self.goal_p, self.goal_q = np.zeros(3), ID_Q.copy()   # target now (relative to the start)
        self.sent_p, self.sent_q = np.zeros(3), ID_Q.copy()   # integral of what was published
        self.v_prev, self.w_prev = np.zeros(3), np.zeros(3)
        self.t_prev: float | None = None
        self.gripper = 1.0
        self.mode_pending = self.done_pending = False
        self.held_count = 0           # how many times the watchdog took over

    # -- page side ---------------------------------------------------------------------------------
    def connect(self, t: float) -> None:
        self.connected, self.need_release = True, True

    def restart(self) -> None:
        """A new run: targets relative to where the arm is now; the clutch must be pressed anew."""
        self._hold()
        self.base_p = self.goal_p = self.sent_p = np.zeros(3)
        self.base_q, self.goal_q, self.sent_q = ID_Q.copy(), ID_Q.copy(), ID_Q.copy()
        self.v_prev, self.w_prev = np.zeros(3), np.zeros(3)

    def disconnect(self, t: float) -> None:
        self.connected = False
        self._hold()

    def on_input(self, msg: dict[str, Any], t: float) -> None:
        """A validated `input` message (rio_teleop.webxr.protocol) that arrived at time t."""
        self.t_msg = t
        pose = msg["pose"]
        if pose is not None:
            x, y, z, w = pose["q"]
            self.pose = (np.asarray(pose["p"], dtype=np.float64), quat_normalize(np.array([w, x, y, z])))
        else:
            self.pose = None
        self.clutch_in = bool(msg["clutch"])
        self.gripper = 1.0 - float(msg["trigger"])
        self.mode_pending |= bool(msg["mode"])
        self.done_pending |= bool(msg["done"])
        self._update_clutch()

    # -- node side ---------------------------------------------------------------------------------
    def stale(self, t: float) -> bool:
        return not self.connected or t - self.t_msg > self.stale_s

    def step(self, t: float) -> dict[str, Any]:
        """This cycle's sample: twist (robot base frame), gripper (0 closed .. 1 open), buttons."""
        dt = 0.0 if self.t_prev is None else max(t - self.t_prev, 0.0)
        self.t_prev = t
        # the loop integrates trapezoids over our samples: half of the last twist over dt is already
        # committed whatever we publish now; the other half is this sample's
        self.sent_p = self.sent_p + 0.5 * self.v_prev * dt
        self.sent_q = quat_normalize(quat_mul(rotvec_to_quat(0.5 * self.w_prev * dt), self.sent_q))
        if self.stale(t) and (self.engaged or self.anchor is not None):
            self._hold()
        if self.engaged and self.pose is not None and self.anchor is not None:
            d_p, d_r = self._displacement()
            if self.mapping == "pose":
                self.goal_p = self.base_p + d_p
                self.goal_q = quat_normalize(quat_mul(rotvec_to_quat(d_r), self.base_q))
        if self.mapping == "pose":
            v, w = self._chase()
        elif self.engaged and self.pose is not None and self.anchor is not None:
            d_p, d_r = self._displacement()
            n = float(np.linalg.norm(d_p))
            v = _clip(d_p * (self.twist_gain * max(n - self.dead_band, 0.0) / n), self.max_speed) if n > 0 else d_p
            w = _clip(d_r * self.twist_gain, self.max_rot_speed)
        else:
            v, w = np.zeros(3), np.zeros(3)
        self.sent_p = self.sent_p + 0.5 * v * dt
        self.sent_q = quat_normalize(quat_mul(rotvec_to_quat(0.5 * w * dt), self.sent_q))
        self.v_prev, self.w_prev = v, w
        buttons = np.zeros(self.n_buttons, bool)
        if self.n_buttons > 0:
            buttons[0] = self.mode_pending  # rio.control.teleop.BUTTON_MODE
        if self.n_buttons > 1:
            buttons[1] = self.done_pending  # BUTTON_DONE
        self.mode_pending = self.done_pending = False
        return {"twist": np.concatenate([v, w]), "gripper": float(self.gripper), "buttons": buttons}

    def status(self, t: float) -> dict[str, Any]:
        return {"connected": self.connected, "stale": self.stale(t), "engaged": self.engaged,
                "need_release": self.need_release, "mapping": self.mapping,
                "target_mm": [round(float(x) * 1000, 1) for x in self.goal_p],
                "sent_mm": [round(float(x) * 1000, 1) for x in self.sent_p],
                "gripper": round(float(self.gripper), 3), "holds": self.held_count}

    # -- inside ------------------------------------------------------------------------------------
    def _update_clutch(self) -> None:
        if not self.clutch_in:
            self.need_release = False
            if self.engaged:
                self.engaged, self.anchor = False, None
                self.base_p, self.base_q = self.goal_p.copy(), self.goal_q.copy()
            return
        if not self.engaged and not self.need_release and self.pose is not None:
            self.engaged = True
            self.anchor = (self.pose[0].copy(), self.pose[1].copy())
            self.base_p, self.base_q = self.goal_p.copy(), self.goal_q.copy()

    def _hold(self) -> None:
        """Watchdog: stop where the arm is, forget the anchor, wait for a fresh clutch press."""
        if self.engaged:
            self.held_count += 1
        self.engaged, self.anchor, self.need_release = False, None, True
        self.goal_p, self.goal_q = self.sent_p.copy(), self.sent_q.copy()
        self.base_p, self.base_q = self.goal_p.copy(), self.goal_q.copy()

    def _displacement(self) -> tuple[np.ndarray, np.ndarray]:
        assert self.pose is not None and self.anchor is not None
        d_p = self.scale * (self.R @ (self.pose[0] - self.anchor[0]))
        d_r = self.rot_scale * (self.R @ quat_to_rotvec(quat_mul(self.pose[1], quat_conj(self.anchor[1]))))
        return d_p, d_r

    def _chase(self) -> tuple[np.ndarray, np.ndarray]:
        e_p = self.goal_p - self.sent_p
        e_r = quat_to_rotvec(quat_mul(self.goal_q, quat_conj(self.sent_q)))
        v = np.zeros(3) if np.linalg.norm(e_p) < SETTLED_M else _clip(self.gain * e_p, self.max_speed)
        w = np.zeros(3) if np.linalg.norm(e_r) < SETTLED_RAD else _clip(self.gain * e_r, self.max_rot_speed)
        return v, w


class HandMapper:
    """`hands` messages -> the hand tracker contract (both hands, index 0 left, 1 right).

    Positions are turned into the robot's axes (`xr_to_robot(yaw_deg)`), not moved: the origin stays
    the reference space's (local-floor: the floor under where the session started). A wrist's
    orientation is the WebXR wrist joint's orientation with the world turned the same way (q_robot =
    R * q_xr; the hand's own axes stay WebXR's joint axes). A hand is tracked while the newest `hands`
    message that had it arrived within `stale_s` and the page is connected; while it is not, its values
    stay as last seen. The gripper is `pinch_opening` of the driving hand (`hand`), held while that hand is not
    tracked (open until it first is). Buttons: done from the page's Finish button (any message's
    `done`), latched until `restart()` (the node's `reset()`: a new run) so a loop that reads only the
    newest sample cannot miss it; mode never (a hand tracker's loop has no modes to cycle).
    """

    SIDES = ("left", "right")

    def __init__(self, *, yaw_deg: float = 0.0, stale_s: float = 0.25, hand: str = "right", buttons: int = 2):
        if hand not in self.SIDES:
            raise ValueError(f"hand must be 'left' or 'right', not {hand!r}")
        self.R = xr_to_robot(yaw_deg)
        self.q_R = matrix_to_quat(self.R)
        self.stale_s, self.hand, self.n_buttons = float(stale_s), self.SIDES.index(hand), int(buttons)
        sample = hand_tracker_sample()
        self.wrist_pose, self.keypoints = sample["wrist_pose"], sample["hand_keypoints"]
        self.t_seen = np.full(2, -np.inf)  # arrival of the newest message that had each hand
        self.connected = False
        self.t_msg = -np.inf
        self.gripper = 1.0
        self.done_pending = False
        self.was_tracked = np.zeros(2, bool)
        self.lost_count = 0           # how many times a tracked hand went stale (the watchdog)
        self.frames = 0

    # -- page side ---------------------------------------------------------------------------------
    def connect(self, t: float) -> None:
        self.connected = True

    def disconnect(self, t: float) -> None:
        self.connected = False
        self.t_seen[:] = -np.inf

    def restart(self) -> None:
        """A new run: forget the hands until the page sends them again."""
        self.t_seen[:] = -np.inf
        self.done_pending = False

    def on_input(self, msg: dict[str, Any], t: float) -> None:
        """An `input` message: keeps the link fresh and carries the page's Finish button."""
        self.t_msg = t
        self.done_pending |= bool(msg["done"])

    def on_hands(self, msg: dict[str, Any], t: float) -> None:
        """A validated `hands` message (rio_teleop.webxr.protocol) that arrived at time t."""
        self.t_msg = t
        self.frames += 1
        for i, side in enumerate(self.SIDES):
            h = msg[side]
            if h is None:
                self.t_seen[i] = -np.inf
                continue
            kp = np.asarray(h["j"], dtype=np.float64) @ self.R.T
            x, y, z, w = h["q"]
            self.keypoints[i] = kp
            self.wrist_pose[i, :3] = kp[0]
            self.wrist_pose[i, 3:] = quat_normalize(quat_mul(self.q_R, np.array([w, x, y, z])))
            self.t_seen[i] = t

    # -- node side ---------------------------------------------------------------------------------
    def tracked(self, t: float) -> np.ndarray:
        return (t - self.t_seen <= self.stale_s) & self.connected

    def stale(self, t: float) -> bool:
        return not self.connected or t - self.t_msg > self.stale_s

    def step(self, t: float) -> dict[str, Any]:
        """This cycle's sample: the hand tracker contract, twist zero."""
        tracked = self.tracked(t)
        self.lost_count += int(np.sum(self.was_tracked & ~tracked))
        self.was_tracked = tracked
        if tracked[self.hand]:
            self.gripper = pinch_opening(self.keypoints[self.hand])
        buttons = np.zeros(self.n_buttons, bool)
        if self.n_buttons > 1:
            buttons[1] = self.done_pending  # rio.control.teleop.BUTTON_DONE, latched until restart()
        return {"twist": np.zeros(6), "gripper": float(self.gripper), "buttons": buttons,
                "wrist_pose": self.wrist_pose.copy(), "hand_keypoints": self.keypoints.copy(), "tracked": tracked}

    def status(self, t: float) -> dict[str, Any]:
        tracked = self.tracked(t)
        wrist = [round(float(x) * 1000, 1) for x in self.wrist_pose[self.hand, :3]]
        return {"connected": self.connected, "stale": self.stale(t), "engaged": bool(tracked[self.hand]),
                "need_release": False, "mapping": "hands", "target_mm": wrist, "sent_mm": wrist,
                "gripper": round(float(self.gripper), 3), "holds": self.lost_count,
                "hands": {side: bool(tracked[i]) for i, side in enumerate(self.SIDES)}, "frames": self.frames}
