"""`XArmConnection`: one SDK connection to one xArm control box, shared by every node of a process that
addresses it.

The arm and its grippers are separate nodes (a gripper can be swapped without touching the arm), but
they are one control box: in one process they share one `XArmAPI` (one command socket, one real-time
report stream). Nodes in other processes open their own connection; the control box accepts several.

State comes from the controller's real-time report (port 30003, `report_type="real"`): the SDK's report
thread hands every report to a callback here, stamped on RIO's clock on arrival, so a node reads the
latest joints without a command round trip and can tell a stale stream from a live one.

Every SDK return code goes through `check()`: 0 passes; "the controller has an error" becomes an
`XArmFault` naming the fault; anything else an `XArmError` naming the call. A dropped command socket
is noticed (`connected`), and `reconnect()` opens a fresh one without the nodes noticing beyond
`connected = False` while it is down.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Any

import numpy as np

from rio import clock

from .faults import STOPPED as STOPPED_FAULT
from .faults import WARNINGS, Fault, XArmError, XArmFault, XArmLost, fault_of
from .models import ArmModel, get_arm, model_of

log = logging.getLogger("rio_ufactory")

#: SDK codes that mean "the controller is in an error state" (has error / not ready to move).
_FAULT_CODES = {1, 9, -2}
#: SDK codes that mean the link is gone: not connected, reply timeout, send failed.
_LOST_CODES = {-1, 3, 8}
#: Controller state "stopped" (after an error, an emergency stop or set_state(4)).
STOPPED = 4
SERVO_MODE = 1


class XArmConnection:
    _shared: dict[str, XArmConnection] = {}
    _guard = threading.Lock()

    def __init__(self, ip: str, connect_timeout_s: float):
        self.ip, self.connect_timeout_s = ip, connect_timeout_s
        self.api: Any = None
        self.model: ArmModel | None = None
        self.users = 0
        self.lock = threading.RLock()  # one command at a time from the nodes sharing the connection
        self._angles = np.zeros(7)
        self._pose = np.zeros(6)
        self._vel = np.zeros(7)
        self.t_report = -np.inf  # RIO clock time of the last real-time report
        self.reports = 0
        self._last_try = -np.inf

    # -- sharing ------------------------------------------------------------------------------------
    @classmethod
    def acquire(cls, ip: str, *, model: str | None = None, connect_timeout_s: float = 5.0) -> XArmConnection:
        """The process's connection to `ip`, opened on first use; `model` is checked against the
        controller's own identity."""
        with cls._guard:
            ctl = cls._shared.get(ip)
            if ctl is None:
                ctl = cls(ip, connect_timeout_s)
                ctl.connect()
                cls._shared[ip] = ctl
            ctl.users += 1
        if model is not None:
            try:
                ctl.expect_model(model)
            except Exception:
                ctl.release()
                raise
        return ctl

    def release(self) -> None:
        with self._guard:
            self.users -= 1
            if self.users > 0:
                return
            self._shared.pop(self.ip, None)
        self.disconnect()

    # -- connection ---------------------------------------------------------------------------------
    def connect(self) -> None:
        from xarm.wrapper import XArmAPI

        from .sdk_log import capture_sdk_output

        capture_sdk_output()  # its healthy-run prints read like faults: into the log (rio --debug shows them)
        deadline = time.monotonic() + self.connect_timeout_s
        while True:
            try:
                api = XArmAPI(self.ip, is_radian=True, report_type="real")
                if api.connected:
                    break
                api.disconnect()
                problem = "the command socket closed at once"
            except Exception as e:  # the SDK raises a bare Exception when nothing answers
                problem = str(e) or type(e).__name__
            if time.monotonic() > deadline:
                raise XArmError(self.ip, "connect", f"no xArm controller answers on TCP 502 within "
                                f"{self.connect_timeout_s:g} s ({problem}); check the IP, the cable and that the "
                                "controller is powered (ping it), or run `rio ufactory emulator`")
            time.sleep(0.2)
        self.api = api
        self.model = model_of(int(api.axis), int(api.device_type))
        api.register_report_location_callback(self._on_report, report_cartesian=True, report_joints=True)
        # The SDK connects the report socket with a 1 s timeout and, if that misses, retries it every 2 s
        # from its report thread: on a loaded machine the first report can take a retry or two.
        if not self.wait_report(max(6.0, deadline - time.monotonic())):
            api.disconnect()
            raise XArmError(self.ip, "connect", "the controller accepted the command socket but sends no real-time "
                            "report on port 30003 (is another program holding it, or a firewall?)")
        log.info("xArm at %s: %s (axis %s, type %s), firmware %s", self.ip,
                 self.model.label if self.model else "unknown model", api.axis, api.device_type, api.version)

    def expect_model(self, name: str) -> None:
        want = get_arm(name)
        if self.model is None or self.model.name != want.name:
            got = self.model.label if self.model else "a model RIO does not know"
            raise XArmError(self.ip, "connect", f"the station says {want.label}, the controller reports {got} "
                            f"(axis {self.api.axis}, device type {self.api.device_type}); fix `model` in the station")

    def disconnect(self) -> None:
        if self.api is not None:
            try:
                self.api.release_location_callback(self._on_report)
            except Exception:
                pass
            self.api.disconnect()
            self.api = None

    @property
    def connected(self) -> bool:
        return self.api is not None and bool(self.api.connected)

    def reconnect(self, period_s: float = 1.0) -> bool:
        """Try once (at most every `period_s`) to open a fresh connection; True when connected."""
        if self.connected:
            return True
        now = time.monotonic()
        if now - self._last_try < period_s:
            return False
        self._last_try = now
        with self.lock:
            self.disconnect()
            saved, self.connect_timeout_s = self.connect_timeout_s, 0.0
            try:
                self.connect()
            except XArmError as e:
                log.warning("%s", e)
                return False
            finally:
                self.connect_timeout_s = saved
        log.warning("xArm at %s: reconnected", self.ip)
        return True

    # -- real-time report -----------------------------------------------------------------------------
    def _on_report(self, msg: dict) -> None:
        t = clock.now()
        angles = np.asarray(msg["joints"], dtype=np.float64)
        dt = t - self.t_report
        if self.reports and 0 < dt < 0.1:
            self._vel = (angles - self._angles) / dt
        self._angles, self._pose, self.t_report = angles, np.asarray(msg["cartesian"], dtype=np.float64), t
        self.reports += 1

    def wait_report(self, timeout: float) -> bool:
        n, t_end = self.reports, time.monotonic() + timeout
        while time.monotonic() < t_end:
            if self.reports > n:
                return True
            time.sleep(0.002)
        return False

    def joints(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """Joint positions and velocities (rad, rad/s) of the first `n` joints, from the last report."""
        return self._angles[:n].copy(), self._vel[:n].copy()

    def tcp_pose(self) -> np.ndarray:
        """`[x, y, z (mm), roll, pitch, yaw (rad)]` from the last report."""
        return self._pose.copy()

    @property
    def report_age(self) -> float:
        return clock.now() - self.t_report

    # -- commands -----------------------------------------------------------------------------------
    def call(self, what: str, *args: Any, **kwargs: Any) -> Any:
        """Call the SDK method `what` and check its code; returns the rest of its result, if any."""
        if not self.connected:
            raise XArmLost(self.ip, what, "not connected (the command socket dropped; reconnecting)")
        with self.lock:
            ret = getattr(self.api, what)(*args, **kwargs)
        code, rest = (ret[0], ret[1:]) if isinstance(ret, (tuple, list)) else (ret, ())
        self.check(code, what)
        return rest[0] if len(rest) == 1 else rest

    def check(self, code: int, what: str) -> None:
        if code == 0:
            return
        if code in _FAULT_CODES:  # an error, or stopped with none (another program, an e-stop on old firmware)
            raise XArmFault(self.ip, what, self.fault() or STOPPED_FAULT)
        if code in _LOST_CODES:
            if self.api is not None:
                self.api.disconnect()  # a controller that stopped answering is reconnected from scratch
            raise XArmLost(self.ip, what, f"SDK code {code} ({_CODE_TEXT.get(code, 'link lost')}); reconnecting")
        if code == 2:  # a warning is pending: the command ran; say it once and clear it
            self.clear_warning()
            return
        raise XArmError(self.ip, what, f"SDK code {code} ({_CODE_TEXT.get(code, 'see the SDK API code table')})")

    def fault(self) -> Fault | None:
        """The controller's current error (asks it), or None."""
        if not self.connected:
            return None
        with self.lock:
            code, (err, _warn) = self.api.get_err_warn_code()
        if code not in (0, 1, 2):
            return None
        return fault_of(err) if err else None

    def clear_warning(self) -> None:
        with self.lock:
            warn = self.api.warn_code
            self.api.clean_warn()
        if warn:
            log.warning("xArm at %s: controller warning W%d (%s), cleared", self.ip, warn,
                        WARNINGS.get(warn, "see the controller warning table"))

    def clear_faults(self) -> None:
        with self.lock:
            self.api.clean_error()
            self.api.clean_warn()
        left = self.fault()
        if left is not None:
            raise XArmFault(self.ip, "clean_error", left)

    def enable_servo(self) -> None:
        """Motors on, servo mode (streamed targets), ready: the state a station drives the arm in."""
        self.call("motion_enable", enable=True)
        self.call("set_mode", SERVO_MODE)
        self.call("set_state", 0)
        # the SDK sets its cached state at once; a report sent before the command can still say "stopped":
        # trust only reports that arrived after it
        n, t_end = self.reports, time.monotonic() + 2.0
        while self.reports < n + 2 or self.api.state == STOPPED or self.api.mode != SERVO_MODE:
            if time.monotonic() > t_end:
                fault = self.fault()
                if fault is not None:
                    raise XArmFault(self.ip, "enable", fault)
                raise XArmError(self.ip, "enable", f"the controller stays in state {self.api.state}, mode "
                                f"{self.api.mode} after enabling servo mode")
            time.sleep(0.005)


_CODE_TEXT = {-1: "not connected", -2: "not ready: the arm is not enabled or is stopped", -7: "joint limit",
              -8: "target out of range", -9: "emergency stop", 3: "reply timeout", 9: "not ready to move",
              12: "parameter error"}
