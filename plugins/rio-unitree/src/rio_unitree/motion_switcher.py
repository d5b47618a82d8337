"""Unitree's motion switcher service over its RPC, on this plugin's own DDS participant (`dds`): which
locomotion mode runs (`check_mode`) and releasing it (`release_mode`): "debug mode", in which the robot
obeys `rt/lowcmd` alone.

The protocol is the SDK's (`unitree_sdk2py.comm.motion_switcher`, `unitree_sdk2py.rpc`): a
`unitree_api` `Request_` on `rt/api/motion_switcher/request` (header: an id, the API id, lease 0,
priority 0; the parameter a JSON string), answered by a `Response_` with the same id on
`rt/api/motion_switcher/response` (status code 0 on success, data a JSON string). Why not the SDK's
`MotionSwitcherClient`: it runs on the SDK's process-wide channel factory (one domain and interface
for the whole process, never closed), see `dds`.
"""

from __future__ import annotations

import json
import time
from typing import Any

from .dds import MOTION_SWITCHER_REQUEST, MOTION_SWITCHER_RESPONSE, Participant

API_VERSION = "1.0.0.1"
CHECK_MODE, SELECT_MODE, RELEASE_MODE = 1001, 1002, 1003


class NoAnswer(TimeoutError):
    pass


class MotionSwitcher:
    """`with MotionSwitcher(interface, domain_id) as ms: ms.check_mode()`."""

    def __init__(self, interface: str, domain_id: int = 0, timeout_s: float = 2.0):
        self.interface, self.domain_id, self.timeout_s = interface, domain_id, timeout_s
        self.dds = Participant(domain_id, interface)
        try:
            self._out = self.dds.writer(MOTION_SWITCHER_REQUEST)
            self._in = self.dds.reader(MOTION_SWITCHER_RESPONSE, depth=16)
        except BaseException:
            self.dds.close()
            raise

    def call(self, api_id: int, parameter: dict[str, Any] | None = None) -> tuple[int, str]:
        """(status code, data) of one call; NoAnswer when the service does not answer in time."""
        from unitree_sdk2py.idl.unitree_api.msg.dds_ import (
            Request_,
            RequestHeader_,
            RequestIdentity_,
            RequestLease_,
            RequestPolicy_,
            Response_,
        )

        t_end = time.monotonic() + self.timeout_s
        if not self._out.wait_matched(self.timeout_s):
            raise NoAnswer(self._silence())
        ident = time.monotonic_ns()
        header = RequestHeader_(RequestIdentity_(ident, api_id), RequestLease_(0), RequestPolicy_(0, False))
        self._out.write(Request_(header, json.dumps(parameter or {}), []).serialize())
        while time.monotonic() < t_end:
            for data in self._in.take():
                resp = Response_.deserialize(data)
                if resp.header.identity.id == ident and resp.header.identity.api_id == api_id:
                    return int(resp.header.status.code), resp.data
            time.sleep(0.005)
        raise NoAnswer(self._silence())

    def _silence(self) -> str:
        return (f"no answer from the motion switcher service (rt/api/motion_switcher) on '{self.interface}' (DDS "
                f"domain {self.domain_id}) within {self.timeout_s} s: is the robot on and heard (`rio unitree "
                "check`)? Without it, enter debug mode with the remote: L2+R2 while the robot hangs in damping")

    def check_mode(self) -> dict[str, Any]:
        """What runs: {"name": <mode, "" when released>, "form": ...}."""
        code, data = self.call(CHECK_MODE)
        if code != 0:
            raise RuntimeError(f"the motion switcher refused CheckMode (code {code})")
        return json.loads(data) if data else {}

    def release_mode(self) -> None:
        code, _ = self.call(RELEASE_MODE)
        if code != 0:
            raise RuntimeError(f"the motion switcher refused ReleaseMode (code {code})")

    def close(self) -> None:
        self.dds.close()

    def __enter__(self) -> MotionSwitcher:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
