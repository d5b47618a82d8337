"""The real backend: a session to a Kinova base through Kinova's `kortex_api`, imported only here and
only when a node with `backend = "kortex"` starts.

kortex_api is not on PyPI: Kinova publishes it as a wheel on GitHub, and it needs an old protobuf.
Two routers: TCP 10000 for `BaseClient` (modes, high-level commands, the gripper, notifications) and
UDP 10001 for `BaseCyclicClient` (feedback, and the 1 kHz low-level commands), each with its own
`SessionManager` session (username/password, the web app's accounts).
"""

from __future__ import annotations

import logging
import types
from typing import Any

from .faults import KinovaError
from .models import INSTALL

log = logging.getLogger("rio_kinova")

TCP_PORT, UDP_PORT = 10000, 10001


def import_kortex() -> types.SimpleNamespace:
    """The kortex modules the driver uses, or an ImportError saying how to install them."""
    try:
        from kortex_api.autogen.client_stubs.BaseClientRpc import BaseClient
        from kortex_api.autogen.client_stubs.BaseCyclicClientRpc import BaseCyclicClient
        from kortex_api.autogen.messages import Base_pb2, BaseCyclic_pb2, Common_pb2, Errors_pb2, Session_pb2
        from kortex_api.Exceptions.KClientException import KClientException
        from kortex_api.Exceptions.KException import KException
        from kortex_api.Exceptions.KServerException import KServerException
        from kortex_api.RouterClient import RouterClient
        from kortex_api.SessionManager import SessionManager
        from kortex_api.TCPTransport import TCPTransport
        from kortex_api.UDPTransport import UDPTransport
    except ImportError as e:
        raise ImportError(f"the Kinova drivers need Kinova's kortex_api ({e}); it is not on PyPI: {INSTALL}") \
            from None
    return types.SimpleNamespace(
        BaseClient=BaseClient, BaseCyclicClient=BaseCyclicClient, Base_pb2=Base_pb2, BaseCyclic_pb2=BaseCyclic_pb2,
        Common_pb2=Common_pb2, Errors_pb2=Errors_pb2, Session_pb2=Session_pb2, KException=KException,
        KServerException=KServerException, KClientException=KClientException,
        RouterClient=RouterClient, SessionManager=SessionManager, TCPTransport=TCPTransport, UDPTransport=UDPTransport)


def open_kortex(key, ip: str, username: str, password: str, timeout_s: float) -> Any:
    from .session import Session

    k = import_kortex()
    opened: list[Any] = []

    def close() -> None:
        for manager, transport in reversed(opened):
            try:
                manager.CloseSession()
            except Exception as e:  # closing goes on for the other router
                log.warning("Kinova base at %s: closing a session: %s", ip, e)
            transport.disconnect()

    def connect(transport_cls, port: int) -> Any:
        transport = transport_cls()
        router = k.RouterClient(transport, lambda e: log.error("Kinova base at %s: router error: %s", ip, e))
        try:
            transport.connect(ip, port)
        except Exception as e:
            raise KinovaError(ip, f"connect on port {port}", f"{e} (is the base at {ip}? `ping {ip}`; your PC needs "
                              "an address on its subnet, e.g. 192.168.1.11/24)") from None
        info = k.Session_pb2.CreateSessionInfo()
        info.username, info.password = username, password
        info.session_inactivity_timeout = int(max(timeout_s, 1.0) * 12000)  # ms
        info.connection_inactivity_timeout = int(max(timeout_s, 1.0) * 400)  # ms
        manager = k.SessionManager(router)
        try:
            manager.CreateSession(info)
        except k.KException as e:
            transport.disconnect()
            raise KinovaError(ip, "create session", f"{e} (check username and password: the web app's "
                                                    "account, admin/admin out of the box)") from None
        opened.append((manager, transport))
        return router

    try:
        base = k.BaseClient(connect(k.TCPTransport, TCP_PORT))
        cyclic = k.BaseCyclicClient(connect(k.UDPTransport, UDP_PORT))
    except Exception:
        close()
        raise
    pb = types.SimpleNamespace(Base_pb2=k.Base_pb2, BaseCyclic_pb2=k.BaseCyclic_pb2, Common_pb2=k.Common_pb2,
                               Errors_pb2=k.Errors_pb2)
    # the base answering "no" (a server exception) is a refusal; no answer at all (a client exception: timeout,
    # connection gone) is a lost session
    return Session(key, ip, base, cyclic, pb, (k.KServerException,), (k.KClientException, OSError), closer=close)
