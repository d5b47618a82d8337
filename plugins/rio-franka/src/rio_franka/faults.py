"""libfranka's errors as named faults a researcher can act on, and clear errors for the set-up
problems that stop a connection (library/firmware version mismatch, FCI not active, no link).

When a reflex fires, libfranka aborts the running motion, the robot stops and holds, and franky
raises `ControlException` on the next command while `robot.state.current_errors` lists the error
flags. RIO names the fault, keeps the node alive with the arm held and refuses commands naming it
until `clear_faults()` (libfranka's automatic error recovery) or `auto_recover`. The flag names are
libfranka's (`franka::Errors`); the meanings and the recovery text are ours.
"""

from __future__ import annotations

import re

from rio.errors import RioError
from rio.interfaces import Fault

RECOVER = "clear it with `rio franka recover --ip IP` (or the node's clear_faults()); the arm then holds where it is"


def _fault(code: int, name: str, meaning: str, recovery: str = RECOVER) -> Fault:
    """A libfranka fault as core's `Fault` (recovery: libfranka's error recovery unless said otherwise)."""
    return Fault(code, name, meaning, recovery)


JOINT_REFLEX = _fault(1, "joint_reflex", "a joint torque or velocity reflex stopped the arm (a joint was pushed "
                                        "harder or moved faster than the collision thresholds allow)")
CARTESIAN_REFLEX = _fault(2, "cartesian_reflex", "a Cartesian force or velocity reflex stopped the arm (the "
                                                "end effector met a force above the collision thresholds)")
COLLISION = _fault(3, "collision", "the arm hit something (libfranka's collision flags are set)",
                  "move the obstacle away (or guide the arm off it with the pilot buttons), then " + RECOVER)
COMMUNICATION = _fault(4, "communication", "the 1 kHz control link missed packets (communication_constraints_"
                                          "violation): the PC did not answer in time",
                      "use a real-time kernel and a direct cable without switches, stop other load, then " + RECOVER)
POWER = _fault(5, "power", "the arm's power limit was exceeded (power_limit_violation): motion too fast with load",
              "lower relative_dynamics_factor, then " + RECOVER)
LIMIT = _fault(6, "limit", "a joint, Cartesian or self-collision limit was violated by the commanded motion",
              "command targets inside the limits, then " + RECOVER)
USER_STOPPED = _fault(7, "user_stopped", "the external enabling device or the user stop is pressed (robot mode "
                                        "'User stopped')", "release the stop button, then " + RECOVER)
LOCKED = _fault(8, "locked", "the robot refuses motion in its current mode: the joints are locked or Desk holds "
                            "control", "open Desk in a browser, unlock the joints and activate FCI, then enable")
LINK_LOST = _fault(4, "communication", "the connection to the robot dropped (no state for a while); RIO reconnects "
                                      "once a second and holds where the arm is once it is back",
                  "check the cable and that the robot is powered; nothing to clear")

#: libfranka's error flags (`franka::Errors` members, as franky names them).
ERROR_FLAGS = (
    "joint_position_limits_violation", "cartesian_position_limits_violation", "self_collision_avoidance_violation",
    "joint_velocity_violation", "cartesian_velocity_violation", "force_control_safety_violation", "joint_reflex",
    "cartesian_reflex", "max_goal_pose_deviation_violation", "max_path_pose_deviation_violation",
    "cartesian_velocity_profile_safety_violation", "joint_position_motion_generator_start_pose_invalid",
    "joint_motion_generator_position_limits_violation", "joint_motion_generator_velocity_limits_violation",
    "joint_motion_generator_velocity_discontinuity", "joint_motion_generator_acceleration_discontinuity",
    "cartesian_position_motion_generator_start_pose_invalid", "cartesian_motion_generator_elbow_limit_violation",
    "cartesian_motion_generator_velocity_limits_violation", "cartesian_motion_generator_velocity_discontinuity",
    "cartesian_motion_generator_acceleration_discontinuity", "cartesian_motion_generator_elbow_sign_inconsistent",
    "cartesian_motion_generator_start_elbow_invalid", "cartesian_motion_generator_joint_position_limits_violation",
    "cartesian_motion_generator_joint_velocity_limits_violation",
    "cartesian_motion_generator_joint_velocity_discontinuity",
    "cartesian_motion_generator_joint_acceleration_discontinuity", "cartesian_position_motion_generator_invalid_frame",
    "force_controller_desired_force_tolerance_violation", "controller_torque_discontinuity",
    "start_elbow_sign_inconsistent", "communication_constraints_violation", "power_limit_violation",
    "joint_p2p_insufficient_torque_for_planning", "tau_j_range_violation", "instability_detected",
    "joint_move_in_wrong_direction", "cartesian_spline_motion_generator_violation",
    "joint_via_motion_generator_planning_joint_limit_violation", "base_acceleration_initialization_timeout",
    "base_acceleration_invalid_reading")


def active_flags(errors) -> list[str]:
    """The set flags of a `franka::Errors` (franky's `Errors`, or the fake's)."""
    return [f for f in ERROR_FLAGS if bool(getattr(errors, f, False))]


def fault_of(flags: list[str], collided: bool = False) -> Fault | None:
    """The named fault of a set of error flags (None when none is set); `collided`: the state's
    joint/cartesian collision flags were set when the reflex fired."""
    if not flags:
        return None
    s = set(flags)
    if "communication_constraints_violation" in s:
        return COMMUNICATION
    if "power_limit_violation" in s:
        return POWER
    if collided and s & {"joint_reflex", "cartesian_reflex"}:
        return COLLISION
    if "joint_reflex" in s:
        return JOINT_REFLEX
    if "cartesian_reflex" in s:
        return CARTESIAN_REFLEX
    if any("limit" in f or f == "self_collision_avoidance_violation" for f in s):
        return LIMIT
    return _fault(9, "controller_error", f"libfranka reported {', '.join(sorted(s))}")


def robot_mode(state) -> str:
    """The state's robot mode as one lower-case word ("userstopped", "reflex", "idle")."""
    m = state.robot_mode
    return str(getattr(m, "name", m)).replace(" ", "").lower()


def fault_of_state(state) -> Fault | None:
    """The named fault a `franka::RobotState` reports (error flags, or the user stop), or None."""
    flags = active_flags(state.current_errors)
    if flags:
        return fault_of(flags, collided=bool(any(state.joint_collision) or any(state.cartesian_collision)))
    if robot_mode(state) == "userstopped":
        return USER_STOPPED
    return None


_FLAGS_IN_TEXT = re.compile(r'"([a-z_]+)"')


def fault_of_message(text: str) -> Fault:
    """The fault a franky `ControlException` / `CommandException` message names."""
    if "current mode" in text:
        return USER_STOPPED if "User stopped" in text else LOCKED
    flags = [f for f in _FLAGS_IN_TEXT.findall(text) if f in ERROR_FLAGS]
    return fault_of(flags) or _fault(9, "controller_error", text.strip().splitlines()[0])


class FrankaError(RioError):
    """franky refused or could not carry a command; names the robot."""

    def __init__(self, ip: str, what: str, detail: str):
        self.ip, self.what = ip, what
        super().__init__(f"Franka at {ip}: {what}: {detail}")


class FrankaSetupError(FrankaError):
    """The connection cannot work as set up (versions, FCI, network, real-time): what to change."""


_VERSIONS = re.compile(r"server version:\s*(\d+).*?library version:\s*(\d+)", re.S)
COMPAT = "https://frankarobotics.github.io/docs/compatibility.html"


def setup_error(ip: str, exc: BaseException, backend_versions: str) -> FrankaSetupError | None:
    """A clear error for a failed connection, or None when the failure is not a known set-up problem.
    `backend_versions`: what is installed here (franky and its bundled libfranka)."""
    text = str(exc)
    name = type(exc).__name__
    if name == "IncompatibleVersionException" or "ncompatible library version" in text:
        m = _VERSIONS.search(text)
        server, lib = (m.group(1), m.group(2)) if m else ("?", "?")
        return FrankaSetupError(
            ip, "libfranka and the robot's firmware do not match",
            f"the robot speaks FCI server version {server}, the installed libfranka speaks {lib} "
            f"({backend_versions}). Install franky built for your robot: `pip install --pre franky-control "
            f"--extra-index-url https://timschneider42.github.io/franky/whl/by-robot-server-version/{server}/` "
            f"(Panda / older FR3 firmware need an older libfranka; see {COMPAT}). Alternative: pylibfranka of the "
            "matching libfranka version (not installed here; it cannot share a process with franky)")
    if "FCI" in text and ("refused" in text or "enable" in text or "activate" in text):
        return FrankaSetupError(ip, "FCI is not active", f"{text.strip()} - open Desk (https://{ip}), unlock the "
                                "joints, then activate FCI in the menu (the robot's lights turn blue/white)")
    if name == "RealtimeException" or "realtime" in text.lower():
        return FrankaSetupError(ip, "no real-time scheduling", f"{text.strip()} - use a PREEMPT_RT kernel (see "
                                "the README) or, for a first try only, `realtime = false` in the station")
    if name == "NetworkException":
        return FrankaSetupError(ip, "cannot reach the robot", f"{text.strip()} - check the static IP of your PC's "
                                "port (same subnet as the robot's FCI address, e.g. 172.16.0.1/24), the cable to "
                                "the control box's FCI port (not the arm base), and `ping " + ip + "`")
    return None
