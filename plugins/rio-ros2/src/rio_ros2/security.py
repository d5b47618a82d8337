"""Who can reach the bridge, decided the way a station's network middlewares decide it
(`rio.runtime.transport.NetworkConfig`): its zenoh session listens and connects on loopback only, unless
this machine's keys are given (`--keys`, made by `rio keys generate`: mutual TLS with the station's CA on
every link, and zenoh access control that lets only the machines those keys trust exchange ROS traffic)
or `--insecure` accepts the risk, which every start then states.

Why: a bridge with commands subscribes to `joint_trajectory` and `cmd_vel`; a session listening on
0.0.0.0, or connected to a router on another machine, without authentication lets anyone who reaches the
port move the robot. A station file with `host = "0.0.0.0"` and no keys has always been refused; the
bridge was the open door beside it.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

from rio.errors import ConfigError
from rio.middleware.protocol.config import is_loopback

if TYPE_CHECKING:
    from .station import RosOptions

log = logging.getLogger("rio.ros2")

#: What ROS 2 traffic over rmw_zenoh is made of, in zenoh's access-control terms.
ROS_MESSAGES = ["put", "delete", "declare_subscriber", "query", "declare_queryable", "reply", "liveliness_token",
                "declare_liveliness_subscriber", "liveliness_query"]


def key_exprs(domain: int) -> list[str]:
    """Everything of one ROS domain: its data and its graph (rmw_zenoh's liveliness tokens)."""
    return [f"{domain}/**", f"@ros2_lv/{domain}/**"]


def exposed(ros: RosOptions) -> list[str]:
    """The endpoints the bridge would listen or connect on beyond this machine."""
    return [e for e in (*ros.listen, *ros.connect) if not is_loopback(e)]


def check(ros: RosOptions) -> Any:
    """Refuse (ConfigError, naming the options) endpoints beyond loopback without keys or `insecure`;
    returns this machine's keys (`rio.machine.keys.MachineKeys`, checked) or None. Run before anything
    starts."""
    if ros.keys is not None:
        from rio.machine.keys import load

        return load(ros.keys)
    out = exposed(ros)
    if out and not ros.insecure:
        opts = sorted({"--listen" if e in ros.listen else "--connect" for e in out})
        risk = ("command the robot (joint_trajectory, cmd_vel)" if ros.commands else
                "read everything the station publishes")
        raise ConfigError(f"{' and '.join(opts)} {', '.join(out)}: reachable from other machines without "
                          f"authentication, and anyone who reaches it could {risk}: give this machine's keys "
                          "(--keys ~/.config/rio/keys/<station>, made by `rio keys generate`; every link is then "
                          "mutual TLS), keep the bridge on 127.0.0.1 and reach it through an ssh tunnel or a VPN, "
                          "or pass --insecure to accept that risk")
    return None


def warn_if_exposed(ros: RosOptions) -> str | None:
    """Every start of a bridge that `insecure` lets beyond loopback says so (returns the line, logged too)."""
    out = exposed(ros)
    if not out or ros.keys is not None:
        return None
    line = (f"ROS 2 bridge on {', '.join(out)} WITHOUT authentication (--insecure): anyone who can reach it can "
            "read the station and" + (" command its arms" if ros.commands else " see everything it publishes"))
    log.warning(line)
    return line
