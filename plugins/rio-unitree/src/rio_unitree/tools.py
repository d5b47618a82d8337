"""What `rio unitree check`, `damp` and `stand` do, as functions (the CLI prints, tests call).

`check` is the first bring-up step: before any driver, does this machine see the robot? Interface
present, an IPv4 address on it (the G1's network is 192.168.123.0/24: the robot's computer is .161,
take e.g. .222), then rt/lowstate arriving with a good CRC, and what it says.
"""

from __future__ import annotations

import socket
import struct
import time
from dataclasses import dataclass, field

import numpy as np

from rio.interfaces.damping import tilt_from_quat

from .dds import ARM_SDK, LOWCMD, LOWSTATE, Participant, interfaces
from .g1 import HOME, JOINTS, NUM_SLOTS, joint_names
from .wire import LowState, state_crc_ok, state_signature


def ipv4_of(interface: str) -> str | None:
    """The interface's IPv4 address (Linux), or None."""
    try:
        import fcntl
    except ImportError:  # not Linux: say nothing rather than something wrong
        return None
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            raw = fcntl.ioctl(s.fileno(), 0x8915, struct.pack("256s", interface[:15].encode()))  # SIOCGIFADDR
        except OSError:
            return None
    return socket.inet_ntoa(raw[20:24])


@dataclass
class CheckReport:
    ok: bool = False
    lines: list[str] = field(default_factory=list)
    problem: str = ""


def check(interface: str, domain_id: int = 0, timeout_s: float = 3.0) -> CheckReport:
    r = CheckReport()
    if interface not in interfaces():
        r.problem = f"no interface '{interface}' here (there are {', '.join(interfaces())})"
        return r
    addr = ipv4_of(interface)
    if addr is None and interface != "lo":
        r.problem = (f"interface '{interface}' has no IPv4 address: give it one on the robot's network, e.g. "
                     f"`sudo ip addr add 192.168.123.222/24 dev {interface}`")
        return r
    r.lines.append(f"interface {interface}: {addr or 'loopback'}")
    if addr and interface != "lo" and not addr.startswith("192.168.123."):
        r.lines.append(f"  note: {addr} is not on the G1's network 192.168.123.0/24")
    with Participant(domain_id, interface) as p:
        reader = p.reader(LOWSTATE, depth=64)
        arm_sdk = p.writer(ARM_SDK)  # writes nothing: asks discovery whether anyone reads rt/arm_sdk
        t0 = time.monotonic()
        seen = {"signed": 0, "unsigned": 0, "wrong": 0}
        first, last = None, None
        while time.monotonic() - t0 < timeout_s and (seen["signed"] + seen["unsigned"] < 50 or
                                                     time.monotonic() - t0 < 0.5):
            for data in reader.take():
                signature = state_signature(data)
                seen[signature] += 1
                if signature != "wrong":
                    last = data
                    first = first if first is not None else time.monotonic()
            time.sleep(0.002)
        span = time.monotonic() - first if first is not None else 0.0
        arm_sdk_readers = arm_sdk.matched()
    if last is None:
        r.problem = (f"no rt/lowstate on '{interface}' (DDS domain {domain_id}) within {timeout_s} s"
                     + (f" ({seen['wrong']} arrived with a wrong CRC)" if seen["wrong"] else "")
                     + ": is the robot on and this cable on its network? (a firewall blocking UDP also does this); "
                       "another DDS domain? --domain-id N (the robot's is 0, unitree_mujoco's 1)")
        return r
    s = LowState.decode(last)
    heard = seen["signed"] + seen["unsigned"]
    rate = (heard - 1) / span if span > 0 and heard > 1 else float("nan")
    live = [j for j in JOINTS if s.mode[j.slot] != 0 or s.q[j.slot] != 0.0]
    r.lines += [f"rt/lowstate: {heard} messages ({rate:.0f} Hz), {seen['wrong']} with a wrong CRC"]
    if seen["unsigned"]:
        r.lines.append(f"  unsigned state: {seen['unsigned']} of them carry no CRC (0), as a simulator such as "
                       "unitree_mujoco publishes: the driver believes them with peer = \"simulator\" only")
    r.lines += [f"mode_machine {s.mode_machine}, mode_pr {s.mode_pr}, tick {s.tick}",
                f"joints reporting: {len(live)} of {len(JOINTS)}",
                f"IMU: quaternion {np.round(s.quaternion, 3).tolist()}, "
                f"tilt {tilt_from_quat(s.quaternion):.1f} deg, gyro "
                f"{np.round(s.gyroscope, 3).tolist()} rad/s",
                f"rt/arm_sdk: read by {arm_sdk_readers}" if arm_sdk_readers else
                "rt/arm_sdk: nobody reads it (Unitree's locomotion does on the robot; a simulator such as "
                "unitree_mujoco does not): control = \"lowcmd\" only"]
    r.ok = True
    return r


def damp(interface: str, domain_id: int = 0, seconds: float = 3.0, rate_hz: float = 500.0) -> int:
    """Publish damping (kp = 0, each joint's damping kd) on rt/lowcmd for `seconds`; the number sent.
    Echoes the robot's mode_machine when its lowstate is heard within 0.5 s."""
    from .commands import ENABLE, MODE_PR
    from .wire import LowCmd

    cmd = LowCmd(mode_pr=MODE_PR)
    for j in JOINTS:
        cmd.mode[j.slot], cmd.kd[j.slot] = ENABLE, j.damping
    assert cmd.mode.size == NUM_SLOTS
    sent = 0
    with Participant(domain_id, interface) as p:
        states, out = p.reader(LOWSTATE), p.writer(LOWCMD)
        t_end = time.monotonic() + 0.5
        while time.monotonic() < t_end:
            data = states.latest()
            if data is not None and state_crc_ok(data):
                cmd.mode_machine = LowState.decode(data).mode_machine
                break
            time.sleep(0.01)
        t_end = time.monotonic() + seconds
        while time.monotonic() < t_end:
            out.write(cmd.encode())
            sent += 1
            time.sleep(1.0 / rate_hz)
    return sent


@dataclass
class StandReport:
    ok: bool = False
    sent: int = 0
    start: np.ndarray | None = None  # the pose it started from (rad, slot order of the G1's 29 joints)
    error: float = float("nan")  # max |q - home| at the end of the hold (rad)
    problem: str = ""
    lines: list[str] = field(default_factory=list)


def _smoothstep(u: float) -> float:
    u = min(1.0, max(0.0, u))
    return u * u * (3.0 - 2.0 * u)


def stand(interface: str, domain_id: int = 0, seconds: float = 5.0, hold_s: float = 2.0, rate_hz: float = 500.0,
          dof: int = 29, state_timeout_s: float = 0.25, fall_tilt_deg: float = 45.0,
          check_mode_timeout_s: float = 1.0) -> StandReport:
    """Ramp every joint from where it is to the home pose (`g1.HOME`) over `seconds` on rt/lowcmd with the
    driver's default gains (smoothstep in time: no jerk at either end), hold it `hold_s`, then damping.

    Refuses (nothing sent) when the motion switcher says a locomotion mode still runs (lowcmd would fight
    it: enter debug mode first). Stops with damping when rt/lowstate goes silent for `state_timeout_s` or
    the pelvis tilts beyond `fall_tilt_deg`."""
    from .commands import Commands
    from .motion_switcher import MotionSwitcher, NoAnswer

    r = StandReport()
    joints = [j for j in JOINTS if j.name in set(joint_names(dof))]
    lower, upper = np.array([j.lower for j in joints]), np.array([j.upper for j in joints])
    wire = Commands(joints, [j.kp for j in joints], [j.kd for j in joints], [j.damping for j in joints],
                    lower, upper, True, dof)
    slots = wire.slots
    home = np.clip([HOME.get(j.name, 0.0) for j in joints], lower, upper)
    try:
        with MotionSwitcher(interface, domain_id, timeout_s=check_mode_timeout_s) as ms:
            mode = ms.check_mode().get("name", "")
    except NoAnswer:
        r.lines.append("motion switcher: no answer (going on: a simulator, or a robot without the service)")
        mode = ""
    if mode:
        r.problem = (f"the robot runs locomotion mode '{mode}': lowcmd would fight it. Hang the robot, then "
                     f"`rio unitree debug-mode --interface {interface}` (or L2+R2 on the remote in damping)")
        return r
    with Participant(domain_id, interface) as p:
        states, out = p.reader(LOWSTATE), p.writer(LOWCMD)
        state, t_state = None, time.monotonic()
        t_end = time.monotonic() + 2.0
        while state is None and time.monotonic() < t_end:
            data = states.latest()
            if data is not None and state_crc_ok(data):
                state, t_state = LowState.decode(data), time.monotonic()
            time.sleep(0.002)
        if state is None:
            r.problem = f"no rt/lowstate on '{interface}' (DDS domain {domain_id}) within 2 s: nothing sent"
            return r
        out.wait_matched(1.0)
        q0 = state.q[slots].astype(np.float64)
        r.start = q0.copy()
        r.lines.append(f"from the current pose (largest move {np.abs(home - q0).max():.2f} rad) to home over "
                       f"{seconds} s, then hold {hold_s} s")
        t0, period = time.monotonic(), 1.0 / rate_hz
        try:
            while True:
                now = time.monotonic()
                data = states.latest()
                if data is not None and state_crc_ok(data):
                    state, t_state = LowState.decode(data), now
                if now - t_state > state_timeout_s:
                    r.problem = f"rt/lowstate went silent for {now - t_state:.2f} s: stopped (damping)"
                    break
                tilt = tilt_from_quat(state.quaternion)
                if tilt > fall_tilt_deg:
                    r.problem = f"the pelvis tilted {tilt:.0f} deg: stopped (damping)"
                    break
                if now - t0 > seconds + hold_s:
                    r.error = float(np.abs(state.q[slots] - home).max())
                    r.ok = True
                    break
                goal = q0 + (home - q0) * _smoothstep((now - t0) / seconds if seconds > 0 else 1.0)
                out.write(wire.position(goal, state.q[slots].astype(np.float64), state.mode_machine).encode())
                r.sent += 1
                time.sleep(max(0.0, period - (time.monotonic() - now)))
        finally:  # whatever happened (Ctrl-C too): soft, not a frozen stiff pose
            damping = wire.damping(state.mode_machine).encode()
            for _ in range(int(0.1 * rate_hz)):
                out.write(damping)
                time.sleep(period)
    return r

