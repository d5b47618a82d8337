"""The emulator's servo port (TCP 30020 here; not a UR port): the stand-in for the URScript that
ur-rtde's `RTDEControlInterface` uploads to the controller (port 30003) and then drives through RTDE
input registers. Emulating that script means interpreting URScript, which is out of reach; instead the
driver's fake control object (`rio_ur.control.EmulatedControl`) sends one line per call here:

    servoj <lookahead> <q1..q6>        -> "ok" | "stopped"   (the target, as servoJ)
    servol <lookahead> <x y z rx ry rz> -> "ok" | "stopped"  (a TCP pose, solved to joints here, as servoL)
    stop                                -> "ok"              (servoStop)
    tcp <x y z rx ry rz>                -> "ok"              (setTcp)

A client that starts with the line `control` is the control script: while one is connected the
script runs (RTDE `runtime_state` PLAYING), as on a real UR. Tests and the station's emulator node use the
same port for what a person does at the robot (ur-rtde's blocking calls hold Python's GIL, so the
emulator always runs in a process of its own and is steered from outside):

    state                               -> one line of JSON (joints, modes, servo command count)
    inject protective_stop | emergency_stop | release_emergency_stop | drop | speed <f> | remote <0|1>
    inject reset                        -> a freshly booted controller at home (one process, many tests)
"""

from __future__ import annotations

import json
import socket
from typing import Any

import numpy as np

from rio.emulation import TcpDevice

from ..description import description
from .robot import URRobot


class ServoServer(TcpDevice):
    def __init__(self, robot: URRobot, host: str, port: int = 30020):
        super().__init__(host, port)
        self.robot = robot
        self._tcp: list[float] | None = None
        self._ik: Any = self._solver()  # built now: servoL must answer within one cycle

    def serve(self, conn: socket.socket, addr: Any) -> None:
        control = False
        try:
            for line in self.read_lines(conn):
                words = line.split()
                if words == ["control"] and not control:
                    control = True
                    with self.robot.lock:
                        self.robot.control_clients += 1
                        self.robot.servo_stop()
                    conn.sendall(b"ok\n")
                elif words[:2] == ["inject", "drop"]:
                    conn.sendall(b"ok\n")  # answered first: this connection goes too
                    self.inject(words[1:])
                elif words[:1] == ["inject"]:
                    self.inject(words[1:])  # done before the answer: the caller's next step sees it
                    conn.sendall(b"ok\n")
                else:
                    conn.sendall((self.answer(words) + "\n").encode())
        finally:
            if control:
                with self.robot.lock:
                    self.robot.control_clients -= 1
                    self.robot.servo_stop()

    #: set by `UREmulator`: cuts every connection of every server
    drop_all: Any = None

    def inject(self, words: list[str]) -> None:
        r, what = self.robot, words[0] if words else ""
        if what == "drop" and self.drop_all is not None:
            self.drop_all()
        elif what == "speed":
            r.speed_slider = float(words[1])
        elif what == "remote":
            r.remote_control = words[1] == "1"
        elif what == "reset":
            r.reset()
            if self._tcp is not None:
                self._tcp, self._ik = None, self._solver()
        elif what in ("protective_stop", "emergency_stop", "release_emergency_stop"):
            getattr(r, what)()

    def answer(self, words: list[str]) -> str:
        if not words:
            return "?"
        r = self.robot
        if words[0] == "state":
            with r.lock:
                return json.dumps({"q": r.q.tolist(), "target": r.target.tolist(), "robot_mode": r.robot_mode,
                                   "safety_mode": r.safety_mode, "servo_commands": r.servo_commands,
                                   "control_clients": r.control_clients, "tcp_pose": r.tcp_pose().tolist()})
        cmd, args = words[0], [float(w) for w in words[1:]]
        if cmd == "servoj":
            return "ok" if r.servo_j(args[1:7], args[0]) else "stopped"
        if cmd == "servol":
            if not r.can_move:
                return "stopped"
            return "ok" if r.servo_j(self._solve(np.asarray(args[1:7])), args[0]) else "stopped"
        if cmd == "stop":
            r.servo_stop()
            return "ok"
        if cmd == "tcp":
            r.set_tcp(args[:6])
            self._tcp = list(args[:6])
            self._ik = self._solver()
            return "ok"
        return "?"

    def _solver(self) -> Any:
        from rio.kinematics import solver_from_description

        try:
            return solver_from_description(description(self.robot.model.name, self._tcp), orientation_cost=1.0,
                                           damping=1e-4)
        except ImportError as e:
            cause = e.__cause__ if isinstance(e.__cause__, ImportError) else e
            raise ImportError(f"the UR emulator's servoL solves IK on the arm model, which needs its solver "
                              f"({cause}): pip install 'rio-ur[ik]'") from None

    def _solve(self, tcp: np.ndarray) -> np.ndarray:
        from rio.control import rotvec_to_quat

        pose = np.concatenate([tcp[:3], rotvec_to_quat(tcp[3:])])
        return self._ik.solve(pose, self.robot.target.copy(), max_iters=15).q
