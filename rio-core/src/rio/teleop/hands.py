"""The hand-tracking teleop controller: a headset's tracked hands drive arms, a humanoid's wrists and
dexterous hands (the device side is `rio.interfaces.teleop`'s hand-tracker contract).

Wrists move tools by their motion, not their place: when a hand is (re)acquired its wrist pose and
the tool's current target are taken as anchors, and from then on the target is the anchor moved by
the wrist's displacement (times `scale`) and turned by the wrist's rotation since, both in the
robot's base axes (the device turns its tracking frame to x forward, y left, z up). The target walks
toward that pose at most `max_pos_speed` / `max_rot_speed` and through the teleop mode's mask, as a
twist device's would (`make_teleop_eef_cmd`), so a tracking glitch can never throw the arm. A hand
that is lost freezes its tool where it is; when it comes back it re-anchors (the operator can walk,
turn or drop their hand without the robot following, like releasing a clutch).

What follows which hand (index 0 left, 1 right):
- one arm: the `hand` given (right by default); its gripper closes with that hand's pinch;
- two arms (`arm` left, `arm2` right) and a humanoid's wrist frames ("left", "right"): same side;
- a dexterous hand: the operator's hand of its own side (its description's `side`), retargeted from
  the keypoints (`rio.kinematics.HandRetargeter`) each cycle while tracked; else it holds.

A humanoid's wrists are solved together on its `robot_description()` (`rio.kinematics.MultiFrameIK`:
only the joints between its root and the wrists move; every other joint is sent as measured at start).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from rio.control.rotations import quat_conj, quat_mul, quat_normalize
from rio.control.se3 import as_pose, twist_between
from rio.control.teleop import EpisodeEnd, TeleopMode, make_teleop_eef_cmd
from rio.errors import RioError
from rio.interfaces.teleop import LEFT, RIGHT, pinch_opening
from rio.teleop.bindings import MAX_TARGET_LEAD_M, bind_arms, build_action
from rio.teleop.feedback import DeviceFeedback
from rio.teleop.twist import DevicePoll

SIDES = {"left": LEFT, "right": RIGHT}


def follow(anchor_wrist: np.ndarray, anchor_target: np.ndarray, wrist: np.ndarray, scale: float) -> np.ndarray:
    """The tool pose that mirrors the wrist's motion since the anchors were taken."""
    p = anchor_target[:3] + scale * (wrist[:3] - anchor_wrist[:3])
    turn = quat_mul(quat_normalize(wrist[3:]), quat_conj(quat_normalize(anchor_wrist[3:])))
    return np.concatenate([p, quat_normalize(quat_mul(turn, anchor_target[3:]))])


class Follower:
    """One tool (an arm's, or a humanoid wrist) following one tracked hand; `holder.target` is the pose."""

    def __init__(self, holder: Any, hand: int):
        self.holder, self.hand = holder, int(hand)
        self.anchor: tuple[np.ndarray, np.ndarray] | None = None

    def __call__(self, tracked: bool, wrist: np.ndarray, h: float, mode: TeleopMode, max_pos_speed: float,
                 max_rot_speed: float, scale: float) -> None:
        if not tracked or not np.isfinite(wrist).all():
            self.anchor = None  # lost: the tool stays; re-anchor when the hand is back
            return
        wrist = as_pose(wrist)
        if self.anchor is None:
            self.anchor = (wrist.copy(), self.holder.target.copy())
            return
        if h <= 0:
            return
        desired = follow(*self.anchor, wrist, scale)
        self.holder.target = make_teleop_eef_cmd(self.holder.target, twist_between(self.holder.target, desired, h),
                                                 h, mode, max_pos_speed, max_rot_speed)


@dataclass
class Wrist:
    """A humanoid wrist as a teleop target: `role` is the arm role it stands for ("arm" the right wrist,
    "arm2" the left: one twist device drives the right hand, a `teleop2` the left); no gripper."""

    name: str
    target: np.ndarray
    role: str = "arm"
    gripper: Any = None


class HumanoidWrists:
    """A humanoid's wrist frames, solved together by IK on its description: what both the hand-tracking
    and the twist teleop move on a humanoid (the upper body; the legs are not on the wrists' chains)."""

    def __init__(self, client: Any):
        from rio.kinematics import MultiFrameIK

        desc = client.robot_description()
        if not desc or not desc.get("frames"):
            raise RioError("the humanoid's driver offers no robot_description() with wrist \"frames\": hand "
                           "tracking cannot place its wrists (docs/teleop.md)")
        self.ik = MultiFrameIK(desc)
        self.q = np.asarray(client.get_state()["joint_pos"], dtype=np.float64).copy()
        self.wrists = {name: Wrist(name, self.ik.fk(self.q, name), "arm2" if name == "left" else "arm")
                       for name in desc["frames"]}
        self.wrists = dict(sorted(self.wrists.items(), key=lambda kv: kv[1].role))  # "arm" (right) first

    def command(self) -> np.ndarray:
        q = self.ik.solve({n: w.target for n, w in self.wrists.items()}, self.q, max_iters=10)
        for n, w in self.wrists.items():  # unreachable: keep the target at the wrist's reach
            fk = self.ik.fk(q, n)
            if np.linalg.norm(fk[:3] - w.target[:3]) > MAX_TARGET_LEAD_M:
                w.target = np.concatenate([fk[:3], w.target[3:]])
        self.q = q
        return q.copy()

    def action(self, robot: Any, hands: dict[str, np.ndarray] | None = None) -> np.ndarray:
        """The humanoid's action: the body's joints from the wrists' targets, each hand's given joints
        (a hand not given holds where it is)."""
        hands = dict(hands or {})
        for role in ("hand", "hand2"):
            if role in robot.clients and role not in hands:
                hands[role] = robot.clients[role].get_state()["joint_pos"]
        return robot.build_action(joint_pos=self.command(), **hands)


class DexterousHand:
    """A robot hand driven by the operator's hand of the same side."""

    def __init__(self, role: str, client: Any, log: Any):
        from rio.kinematics import HandRetargeter

        desc = client.robot_description()
        self.q = np.asarray(client.get_state()["joint_pos"], dtype=np.float64).copy()
        self.retarget = HandRetargeter(desc) if desc else None
        side = str((desc or {}).get("side", "right" if role.endswith("2") else "left"))
        self.hand = SIDES.get(side, RIGHT)
        if self.retarget is None:
            log(f"hand '{role}' offers no robot_description() to retarget onto: it holds still")

    def __call__(self, tracked: bool, keypoints: np.ndarray) -> np.ndarray:
        if tracked and self.retarget is not None and np.isfinite(keypoints).all():
            self.q = self.retarget(keypoints, self.q)
        return self.q.copy()


class HandTeleop:
    """Controller (rio.loop.control_loop): see the module docstring. `device`: the tracker's connected client."""

    name = "teleop"

    def __init__(self, device: Any, *, name: str, hand: str = "right",
                 mode: str | TeleopMode = TeleopMode.TRANSLATION_ROTATION, max_pos_speed: float = 0.15,
                 max_rot_speed: float = 1.0, scale: float = 1.0):
        if hand not in SIDES:
            raise RioError(f"hand '{hand}': write left or right")
        self.device, self.device_name, self.hand = device, name, SIDES[hand]
        self.mode, self.scale = TeleopMode.parse(mode), float(scale)
        self.max_pos_speed, self.max_rot_speed = max_pos_speed, max_rot_speed
        self.end = EpisodeEnd()
        self.arms: list[Any] = []
        self.body: HumanoidWrists | None = None

    def reset(self, loop: Any) -> None:
        robot = loop.env.robot
        if "humanoid" in robot.clients:
            self.body = HumanoidWrists(robot.clients["humanoid"])
            self.followers = [Follower(w, SIDES.get(n, RIGHT)) for n, w in self.body.wrists.items()]
        else:
            self.arms = bind_arms(robot)
            for b in self.arms:
                b.reset_target()
            sides = [self.hand] if len(self.arms) == 1 else [LEFT, RIGHT]
            self.followers = [Follower(b, s) for b, s in zip(self.arms, sides, strict=False)]
        roles = [r for r in ("hand", "hand2") if r in robot.clients]
        self.dex = {r: DexterousHand(r, robot.clients[r], loop.say) for r in roles}
        self.feedback = DeviceFeedback({"teleop": self.device}, log=loop.say)
        if "reset" in dir(self.device):
            self.device.reset()
        # after the device's reset, with a fresh end: a run after another (a recording session) does not read
        # the last run's done button
        self.poll = DevicePoll(self.device)  # buttons OR-ed over every sample since the last cycle
        self.end = EpisodeEnd()
        if "help" in dir(self.device):
            loop.say(self.device.help())
        self.t_prev: float | None = None
        loop.say(f"hand teleop: {self.device_name}, mode {self.mode.name.lower()}, {loop.rate_hz:g} Hz; a hand "
                 "moves its robot from where it is when tracking (re)starts")

    def step(self, tick: Any) -> np.ndarray:
        h = 0.0 if self.t_prev is None else max(tick.t - self.t_prev, 0.0)
        self.t_prev = tick.t
        polled = self.poll(h)
        s = polled["raw"]
        tracked = np.asarray(s["tracked"], dtype=bool)
        wrists = np.asarray(s["wrist_pose"], dtype=np.float64)
        keypoints = np.asarray(s["hand_keypoints"], dtype=np.float64)
        self.end.update(polled["buttons"])
        for f in self.followers:
            f(bool(tracked[f.hand]), wrists[f.hand], h, self.mode, self.max_pos_speed, self.max_rot_speed,
              self.scale)
        hands = {r: d(bool(tracked[d.hand]), keypoints[d.hand]) for r, d in self.dex.items()}
        tick.info.update(devices={"teleop": s}, arms=self.arms, mode=self.mode)
        if self.body is not None:
            return self.body.action(tick.env.robot, hands)
        for f in self.followers:
            b = f.holder
            if b.gripper is not None and tracked[f.hand]:
                b.gripper_cmd = pinch_opening(keypoints[f.hand]) * b.max_width
            if b.hand_label is not None:
                b.hand_cmd = hands.get(b.hand_role)
        return build_action(tick.env.robot, self.arms)

    def after(self, tick: Any) -> None:
        self.feedback(tick.t, self.arms)

    def done(self) -> str | None:
        return self.end.reason()

    def finish(self, summary: Any) -> None:
        summary.details["device"] = self.device_name
        summary.details["mode"] = self.mode.name.lower()
        self.end.report(summary)
