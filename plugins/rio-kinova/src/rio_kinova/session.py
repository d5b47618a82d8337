"""The seam between the nodes and kortex: a `Session` holds a base's `BaseClient`, `BaseCyclicClient`, the
message modules to build commands with, the exceptions a refused call raises, and the base's latest
fault (from its arm state and action notifications). Nodes of one process on one base share it (the arm
and the gripper), counted, so the connection closes with the last.

A call that fails in transport (kortex's client-side exceptions: no answer, the connection gone) marks
the session lost; `reconnect()` opens fresh clients into the same `Session` object (at most once a
second), so every node holding it carries on with them.

`backend` picks where the clients come from: "kortex" (a real base, `kortex.py`), "fake" (stand-ins with
Gen3-like behaviour, `fake/`), or "sim" / "sim:ARM@WORLD" (the stand-ins driving a rio-sim world's arm).
The driver code is the same for all three.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from .faults import Fault, from_action_abort, from_arm_state
from .models import ArmModel

log = logging.getLogger("rio_kinova")


@dataclass
class Session:
    key: tuple[str, str, str]
    ip: str
    base: Any
    cyclic: Any
    pb: Any  # namespace with Base_pb2, BaseCyclic_pb2, Common_pb2, Errors_pb2
    errors: tuple[type[BaseException], ...]  # the base refused the call
    lost_errors: tuple[type[BaseException], ...] = (OSError,)  # the call never got an answer
    closer: Any = None
    opener: Callable[[], Session] | None = None  # fresh clients to the same base (reconnect)
    alive: bool = True
    last_try: float = 0.0
    robot: Any = None  # the FakeRobot behind a fake session (tests inject faults through it)
    fault: Fault | None = None
    users: int = 0
    handles: list[Any] = field(default_factory=list)

    def subscribe(self) -> None:
        """Follow the base's arm state and action notifications into `fault`."""
        opts = self.pb.Common_pb2.NotificationOptions()
        self.handles = [self.base.OnNotificationArmStateTopic(self._on_arm_state, opts),
                        self.base.OnNotificationActionTopic(self._on_action, opts)]

    def _name(self, enum: Any, value: int) -> str:
        try:
            return enum.Name(int(value))
        except Exception:  # an enum value this kortex version does not know
            return str(value)

    def _on_arm_state(self, note: Any) -> None:
        state = self._name(self.pb.Common_pb2.ArmState, note.active_state)
        fault = from_arm_state(state, self.fault.meaning if self.fault else "")
        if fault is None:
            return  # a state that is no fault; clearing is done by clear_faults()
        if self.fault is None or self.fault.name == "in_fault" and fault.name != "in_fault":
            self.fault = fault

    def _on_action(self, note: Any) -> None:
        if int(note.action_event) != int(self.pb.Base_pb2.ACTION_ABORT):
            return
        fault = from_action_abort(self._name(self.pb.Errors_pb2.SubErrorCodes, note.abort_details))
        if self.fault is None or self.fault.name in ("in_fault", "action_aborted"):
            self.fault = fault

    def arm_state(self) -> str:
        return self._name(self.pb.Common_pb2.ArmState, self.base.GetArmState().active_state)

    def close(self) -> None:
        if self.closer is not None:
            try:
                self.closer()
            except Exception as e:  # a lost session may not close cleanly; the new one replaces it anyway
                log.debug("Kinova base at %s: closing: %s", self.ip, e)
            self.closer = None

    def reconnect(self, period_s: float = 1.0) -> bool:
        """Fresh clients after a lost session (tried at most every `period_s`); True when alive."""
        with _lock:
            if self.alive:
                return True
            now = time.monotonic()
            if self.opener is None or now - self.last_try < period_s:
                return False
            self.last_try = now
            self.close()
            try:
                fresh = self.opener()
            except Exception as e:
                log.warning("Kinova base at %s: reconnect failed: %s", self.ip, e)
                return False
            self.base, self.cyclic, self.closer, self.robot = fresh.base, fresh.cyclic, fresh.closer, fresh.robot
            self.fault, self.alive = None, True
            self.subscribe()
        log.warning("Kinova base at %s: session reopened", self.ip)
        return True


_lock = threading.Lock()
_sessions: dict[tuple[str, str, str], Session] = {}


def acquire(backend: str, ip: str, model: ArmModel, username: str, password: str, timeout_s: float) -> Session:
    """The shared session to the base at `ip` through `backend` (opened by the first node)."""
    key = (backend, ip, model.name if backend != "kortex" else "")
    with _lock:
        s = _sessions.get(key)
        if s is None:
            s = _open(backend, key, ip, model, username, password, timeout_s)
            s.opener = _opener(s, backend, model, username, password, timeout_s)
            s.subscribe()
            _sessions[key] = s
        s.users += 1
        return s


def release(session: Session) -> None:
    with _lock:
        session.users -= 1
        if session.users > 0:
            return
        _sessions.pop(session.key, None)
    session.close()
    if session.robot is not None:
        session.robot.close()


def _opener(s: Session, backend: str, model: ArmModel, username: str, password: str,
            timeout_s: float) -> Callable[[], Session]:
    return lambda: _open(backend, s.key, s.ip, model, username, password, timeout_s, robot=s.robot)


def fake_robot(ip: str, model: str, backend: str = "fake") -> Any:
    """The `FakeRobot` behind an open fake session (for tests: inject faults, read what was sent)."""
    return _sessions[(backend, ip, model)].robot


def _open(backend: str, key, ip: str, model: ArmModel, username: str, password: str, timeout_s: float,
          robot: Any = None) -> Session:
    """A new session; for the fake backends, `robot` is the base a reconnect finds again."""
    if backend == "kortex":
        from .kortex import open_kortex

        return open_kortex(key, ip, username, password, timeout_s)
    from .fake import messages
    from .fake.clients import FakeBase, FakeCyclic
    from .fake.robot import FakeLinkError, FakeRobot, FakeServerError

    if robot is not None:  # the same fake base again, if its link is up
        robot.check_link("connect")
        return Session(key, ip, FakeBase(robot), FakeCyclic(robot), messages, (FakeServerError,), (FakeLinkError,),
                       robot=robot)
    plant = None
    if backend.startswith("sim"):
        from .fake.sim import attach

        plant = attach(backend, model, timeout_s)
    robot = FakeRobot(model, plant)
    return Session(key, ip, FakeBase(robot), FakeCyclic(robot), messages, (FakeServerError,), (FakeLinkError,),
                   robot=robot)
