"""`XArmEmulator`: a UFACTORY xArm controller on the network, for the unmodified xArm Python SDK.

It listens where a controller does (command port 502, report ports 30001 normal, 30002 rich, 30003
real-time) on an address of its own, so several run side by side on loopback addresses:

    with XArmEmulator("xarm7", host="127.0.0.2") as emu:
        arm = XArmAPI("127.0.0.2", is_radian=True, report_type="real")
        arm.motion_enable(True); arm.set_mode(1); arm.set_state(0)
        arm.set_servo_angle_j([0.1, 0, 0, 0, 0, 0, 0])

It reports the model's identity (axis count, device type, serial number, firmware 2.x) and moves its
joints with a control loop at 250 Hz: `backend="model"` is a kinematic model of the joints (rate
limit and servo lag), `backend="sim[:ARM[@WORLD]]"` the arm of a running rio-sim world. Faults can be
injected (`inject_fault`), connections dropped (`drop_connections`), and the tool port carries the
configured gripper (`gripper=`: "xarm", "xarm_g2", "bio", "lite6", "robotiq" or None).
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Any

import numpy as np

from rio.kinematics import IKSolver, solver_from_description

from ..description import description
from ..models import ArmModel, get_arm
from . import grippers
from .codes import FAULTS, Err
from .machine import ArmMachine
from .motion import ModelJoints
from .protocol import COMMAND_PORT, REPORT_NORMAL_PORT, REPORT_REAL_PORT, REPORT_RICH_PORT, feedback_frame
from .registers import CommandHandler, FeedbackTag
from .report import encode_normal, encode_real, encode_rich
from .servers import CommandServer, ReportServer
from .sim import SimJoints, attach, parse_backend
from .tool import ToolBoard

log = logging.getLogger("rio_ufactory.emulator")

GRIPPERS = ("xarm", "xarm_g2", "bio", "lite6", "robotiq")
#: Serial-number prefixes per model (digits 2..5 below 1305, so the SDK picks the standard joint table).
_SN_PREFIX = {"xarm5": "XF", "xarm6": "XS", "xarm7": "XI", "xarm850": "XE", "lite6": "LI"}
CONTROL_HZ = 250.0
NORMAL_REPORT_HZ = 10.0
FIRMWARE = "2.6.0"
#: Weight of orientation against position errors in inverse kinematics (1 rad counts as 0.3 m): a 5-axis
#: arm, which cannot hold every orientation, still puts its TCP where it is told.
ORIENTATION_COST = 0.3


def arm_kinematics(arm: ArmModel) -> IKSolver | None:
    """Core's IK solver for the flange (site `tcp`) of the arm's robot description, or None when its MJCF
    or the IK backend (`rio-ufactory[ik]`: mujoco, mink) is missing."""
    if not arm.mjcf_path.exists():
        return None
    try:
        return solver_from_description(description(arm.name), orientation_cost=ORIENTATION_COST)
    except ModuleNotFoundError:
        return None


class XArmEmulator:
    def __init__(self, model: str = "xarm7", host: str = "127.0.0.1", backend: str = "model",
                 gripper: str | None = "xarm", report_hz: float = 250.0, sn: str | None = None, *,
                 robotiq: Any = None, kinematics: IKSolver | None = None, sim_timeout: float = 60.0):
        self.arm = get_arm(model)
        self.host = host
        self.backend = backend
        self.report_hz = float(report_hz)
        sn = sn or f"{_SN_PREFIX.get(self.arm.name, 'XA')}1300EMU00001"
        if len(sn) < 6 or not sn[2:6].isdigit() or "," in sn:
            raise ValueError(f"sn '{sn}': the SDK reads characters 2..5 of a serial number as digits")
        self.sn = sn
        self._world_arm = None
        target = parse_backend(backend)
        if target is None:
            joints: Any = ModelJoints(self.arm.home)
            fingers_for = None
        else:
            self._world_arm = attach(*target, axis=self.arm.axis, model_label=self.arm.label, timeout=sim_timeout)
            joints = SimJoints(self._world_arm)
            fingers_for = self._world_arm
        try:
            self.gripper = self._make_gripper(gripper, robotiq, fingers_for)
            self.tool = ToolBoard(self.gripper)
            kin = kinematics if kinematics is not None else arm_kinematics(self.arm)
            if kin is None:
                log.warning("%s: no kinematic model (%s, mujoco or mink missing: pip install 'rio-ufactory[ik]'): "
                            "poses read 0, Cartesian commands are refused", self.arm.label, self.arm.mjcf_path.name)
            self.machine = ArmMachine(self.arm, joints, self.tool, kin, sn=sn, box_sn="AC1300EMU0001",
                                      firmware=FIRMWARE)
        except Exception:
            joints.close()
            raise
        self.handler = CommandHandler(self.machine)
        self._servers = [
            CommandServer(host, COMMAND_PORT, self.handler.handle),
            ReportServer(host, REPORT_NORMAL_PORT, NORMAL_REPORT_HZ, lambda: encode_normal(self.machine.snapshot)),
            ReportServer(host, REPORT_RICH_PORT, NORMAL_REPORT_HZ, lambda: encode_rich(self.machine.snapshot)),
            ReportServer(host, REPORT_REAL_PORT, self.report_hz, lambda: encode_real(self.machine.snapshot)),
        ]
        self._stop = threading.Event()
        self._loop: threading.Thread | None = None
        self._started = False

    @staticmethod
    def _make_gripper(kind: str | None, robotiq: Any, world_arm: Any):
        if kind in (None, "none"):
            return None
        if kind not in GRIPPERS:
            raise ValueError(f"unknown gripper '{kind}'; known: {', '.join(GRIPPERS)} or None")
        fingers = None
        if world_arm is not None:
            from rio_sim.world_fingers import SimFingers

            fingers = SimFingers(world_arm)
        if kind == "xarm":
            return grippers.XArmGripper(fingers)
        if kind == "xarm_g2":
            return grippers.XArmGripper(fingers, g2=True)
        if kind == "bio":
            return grippers.BioGripper(fingers)
        if kind == "lite6":
            return grippers.Lite6Tool(fingers)
        if robotiq is None:
            try:
                from rio_robotiq.emulator.registers import RobotiqRegisters
            except ImportError as e:
                raise ImportError("gripper='robotiq' needs rio_robotiq.emulator (install rio-robotiq) or a "
                                  "robotiq= object with handle(frame) -> reply") from e
            robotiq = RobotiqRegisters()
            if fingers is not None:
                robotiq.fingers = fingers  # the world's fingers, behind the same FingerModel interface
        return grippers.RobotiqPort(robotiq)

    # -- lifecycle ---------------------------------------------------------------------------------------
    def start(self) -> XArmEmulator:
        """Listen on the controller's ports and start the control loop (idempotent)."""
        if self._started:
            return self
        started = []
        try:
            for s in self._servers:
                s.start()
                started.append(s)
        except Exception:
            for s in started:
                s.stop()
            raise
        self._stop.clear()
        self._loop = threading.Thread(target=self._control_loop, name=f"rio-xarm-emulator-{self.host}", daemon=True)
        self._loop.start()
        self._started = True
        log.info("%s emulator (%s backend, gripper %s) on %s", self.arm.label, self.backend,
                 type(self.gripper).__name__ if self.gripper else "none", self.host)
        return self

    def stop(self) -> None:
        """Close every connection and server and stop the control loop; the rio-sim arm (if any) is
        released, so an emulator with a sim backend is not started again."""
        if not self._started:
            self._close_backend()
            return
        self._started = False
        self._stop.set()
        for s in self._servers:
            s.stop()
        if self._loop is not None:
            self._loop.join(2.0)
            self._loop = None
        self._close_backend()

    def _close_backend(self) -> None:
        try:
            self.machine.motion.backend.close()
        except Exception:
            log.exception("closing the joints' backend")

    def __enter__(self) -> XArmEmulator:
        return self.start()

    def __exit__(self, *exc: Any) -> None:
        self.stop()

    def __repr__(self) -> str:
        return f"<XArmEmulator {self.arm.name} at {self.host} ({self.backend})>"

    # -- the control loop ---------------------------------------------------------------------------------
    def _control_loop(self) -> None:
        period = 1.0 / CONTROL_HZ
        t_last = time.monotonic()
        deadline = t_last
        failures = 0
        while not self._stop.is_set():
            now = time.monotonic()
            dt, t_last = min(now - t_last, 0.1), now
            try:
                with self.machine.lock:
                    events = self.machine.tick(now, dt)
                failures = 0
            except Exception:
                failures += 1
                if failures == 1:
                    log.exception("%s emulator: control tick failed", self.arm.label)
                events = []
            for tag, kind, code in events:
                self._send_feedback(tag, kind, code)
            deadline += period
            delay = deadline - time.monotonic()
            if delay > 0:
                self._stop.wait(delay)
            else:
                deadline = time.monotonic()

    def _send_feedback(self, tag: FeedbackTag, kind: int, code: int) -> None:
        if not tag.kinds & kind:
            return
        frame = feedback_frame(tag.transaction, tag.protocol, self.machine.status_byte(), kind, tag.register, code,
                               t_us=int(time.monotonic() * 1e6))
        tag.conn.send(frame)

    # -- tests and demos -----------------------------------------------------------------------------------
    @property
    def driver_fields(self) -> dict[str, Any]:
        """The station fields that point a rio-ufactory driver at this emulator."""
        return {"ip": self.host}

    @property
    def version(self) -> str:
        return self.machine.version

    @property
    def joint_pos(self) -> np.ndarray:
        with self.machine.lock:
            return self.machine.motion.q.copy()

    @property
    def mode(self) -> int:
        return int(self.machine.mode)

    @property
    def state(self) -> int:
        return int(self.machine.state)

    @property
    def error_code(self) -> int:
        return self.machine.error_code

    @property
    def warn_code(self) -> int:
        return self.machine.warn_code

    @property
    def enabled(self) -> bool:
        return self.machine.enabled

    @property
    def servo_commands(self) -> int:
        return self.machine.servo_commands

    @property
    def last_servo_target(self) -> np.ndarray | None:
        t = self.machine.last_servo_target
        return None if t is None else t.copy()

    @property
    def last_command_time(self) -> float | None:
        return self.machine.last_command_time

    @property
    def clients(self) -> int:
        """Open connections, command and report ports together."""
        return sum(s.clients for s in self._servers)

    def tcp_pose(self) -> np.ndarray:
        """The TCP pose the controller reports: x, y, z (mm), roll, pitch, yaw (rad)."""
        with self.machine.lock:
            return self.machine.snapshot.pose.copy()

    def inject_fault(self, kind: str, joint: int | None = None) -> int:
        """Raise a controller error now, as the hardware would: "collision" (C31), "joint_limit" (C23),
        "estop" (C1, the control box's button; held until `release_estop()`), "estop_io" (C2),
        "servo" (C11..C17 for joint 1..7, C10 without one). The arm stops where it is (state 4).
        Returns the error code."""
        if kind not in FAULTS:
            raise ValueError(f"unknown fault '{kind}'; known: {', '.join(FAULTS)}")
        code = int(FAULTS[kind])
        with self.machine.lock:
            if kind == "servo" and joint is not None:
                if not 1 <= joint <= self.arm.axis:
                    raise ValueError(f"joint {joint}: the {self.arm.label} has joints 1..{self.arm.axis}")
                code = int(Err.SERVO_1) + joint - 1
                self.machine.servo_codes[2 * (joint - 1): 2 * joint] = bytes([1, 11])  # joint current overlimit
            if kind in ("estop", "estop_io"):
                self.machine.estop_pressed = True
            self.machine.fault(code)
        log.info("%s emulator: fault %s -> C%d", self.arm.label, kind, code)
        return code

    def release_estop(self) -> None:
        """Release the emergency stop: `clean_error` can clear C1/C2 from now on."""
        with self.machine.lock:
            self.machine.estop_pressed = False

    def set_warning(self, code: int) -> None:
        """Raise a controller warning (its code), as the controller does on a bad parameter."""
        with self.machine.lock:
            self.machine.warn_code = int(code)

    def drop_connections(self) -> int:
        """Close every client connection (command and reports), as a pulled cable would; the servers keep
        listening. Returns how many were closed."""
        return sum(s.drop_clients() for s in self._servers)
