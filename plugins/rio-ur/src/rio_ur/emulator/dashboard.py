"""The controller's Dashboard Server (TCP 29999): one plain-text command per line, one reply line each,
after the greeting "Connected: Universal Robots Dashboard Server". The replies are the controller's
own wording (PolyScope 5), which ur-rtde's `DashboardClient` parses; an unknown command answers
"could not understand: '<command>'" as the real one does."""

from __future__ import annotations

import socket
from typing import Any

from rio.emulation import TcpDevice

from .robot import PROTECTIVE_STOP, ROBOT_MODES, SAFETY_MODES, URRobot

GREETING = "Connected: Universal Robots Dashboard Server"
POLYSCOPE = "URSoftware 5.15.0.1234 (Jan 01 2024)"


class DashboardServer(TcpDevice):
    def __init__(self, robot: URRobot, host: str, port: int = 29999, serial: str = "20235500001"):
        super().__init__(host, port)
        self.robot, self.serial = robot, serial
        self.commands: list[str] = []  # every command received, for tests

    def serve(self, conn: socket.socket, addr: Any) -> None:
        conn.sendall((GREETING + "\n").encode())
        for line in self.read_lines(conn, errors="replace", bufsize=1024):
            cmd = line.strip()
            if not cmd:
                continue
            self.commands.append(cmd)
            conn.sendall((self.answer(cmd) + "\n").encode())
            if cmd == "quit":
                return

    def answer(self, cmd: str) -> str:  # noqa: PLR0911 (one branch per command)
        r, low = self.robot, cmd.lower()
        if low == "power on":
            r.power_on()
            return "Powering on"
        if low == "power off":
            r.power_off()
            return "Powering off"
        if low == "brake release":
            r.brake_release()
            return "Brake releasing"
        if low == "unlock protective stop":
            if r.safety_mode != PROTECTIVE_STOP:
                return "Protective stop releasing"  # the controller answers the same when nothing is stopped
            r.unlock_protective_stop()
            return "Protective stop releasing"
        if low == "close safety popup":
            return "closing safety popup"
        if low == "close popup":
            return "closing popup"
        if low == "robotmode":
            return f"Robotmode: {ROBOT_MODES.get(r.robot_mode, 'UNKNOWN')}"
        if low == "safetymode":
            return f"Safetymode: {SAFETY_MODES.get(r.safety_mode, 'UNKNOWN')}"
        if low == "safetystatus":
            return f"Safetystatus: {SAFETY_MODES.get(r.safety_mode, 'UNKNOWN')}"
        if low == "programstate":
            name = r.program or "<unnamed>"
            return f"{'PLAYING' if r.program_playing else 'STOPPED'} {name}"
        if low == "running":
            return f"Program running: {'true' if r.program_playing else 'false'}"
        if low == "is in remote control":
            return "true" if r.remote_control else "false"
        if low == "polyscopeversion":
            return POLYSCOPE
        if low == "version":
            return POLYSCOPE.split()[1]
        if low == "get robot model":
            return r.model.label.rstrip("e").upper().replace("UR", "UR")
        if low == "get serial number":
            return self.serial
        if low == "get loaded program":
            return f"Loaded program: {r.program}" if r.program else "No program loaded"
        if low.startswith("load "):
            r.program = cmd[5:].strip()
            return f"Loading program: {r.program}"
        if low == "play":
            if r.program is None:
                return "Failed to execute: play"
            r.program_playing = True
            return "Starting program"
        if low == "stop":
            r.program_playing = False
            return "Stopped"
        if low == "pause":
            r.program_playing = False
            return "Pausing program"
        if low == "restart safety":
            r.safety_mode = 1
            r.robot_mode = 3
            return "Restarting safety"
        if low == "isprogramsaved":
            return f"true {r.program or '<unnamed>'}"
        if low.startswith("popup "):
            return "showing popup"
        if low.startswith("addtolog ") or low.startswith("addtolog"):
            return "Added log message"
        if low == "quit":
            return "Disconnected"
        if low == "shutdown":
            return "Shutting down"
        return f"could not understand: '{cmd}'"
