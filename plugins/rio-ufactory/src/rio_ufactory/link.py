"""What every node on an xArm control box does the same way: hold the faults the box reports and the drops
of the connection it shares (the core's parts, `rio.interfaces.FaultHolder` and `LinkSupervisor`), and send
each command so that a fault or a drop it runs into is held, not raised.

A fault does not end the node (unlike a servo bus error on a hobby arm): the xArm stops and brakes by
itself, the node reports `fault_code` and refuses commands naming the fault, and `clear_faults()` (or
`rio ufactory clear-errors` from a shell, while the station runs) brings it back holding where it is.
A dropped command socket is retried once a second; meanwhile `connected` is false and commands are
refused, and after the reconnect the node holds where the arm is, whatever was commanded before.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rio.interfaces import FaultHolder, LinkSupervisor

from .faults import XArmFault, XArmLost


def hold_faults_and_drops(node: Any) -> None:
    """Give `node` (an arm or a gripper on the control box at `node.config.ip`, connected as `node.conn` once
    open) its fault holder and link supervisor."""
    node.faults = FaultHolder(node, f"xArm at {node.config.ip}", ask=lambda: node.conn.fault(),
                              clear=lambda: node.conn.clear_faults())
    node.link = LinkSupervisor(node.faults, up=lambda: node.conn is not None and node.conn.connected,
                               reconnect=lambda: node.conn.reconnect())


def guarded(node: Any, fn: Callable[..., Any], *args: Any) -> None:
    """Run one device command; a fault the control box answers with is held (named), a lost link is held
    and retried."""
    try:
        fn(*args)
    except XArmFault as e:
        node.faults.report(e.fault)
    except XArmLost:
        node.link.lost()
