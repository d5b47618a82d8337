"""The simulation session of this process tree: one id, set once in the first process and inherited by every
node process it spawns, so that nodes of one station find the same world bus (`rio_sim.bus`) and two
stations started side by side never share one. Kept apart from the bus so the plugin's package can set it
at import without loading numpy (`rio plugins list` imports the package)."""

from __future__ import annotations

import os
import uuid

SESSION_ENV = "RIO_SIM_SESSION"


def session_id() -> str:
    """This process tree's session (set once, inherited by spawned node processes)."""
    sid = os.environ.get(SESSION_ENV)
    if not sid:
        sid = f"{os.getpid()}-{uuid.uuid4().hex[:6]}"
        os.environ[SESSION_ENV] = sid
    return sid
