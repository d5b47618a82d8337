"""`rio ros2 ...`: a station seen from ROS 2 (`bridge`), and the message definitions it uses, as files
(`definitions`). Mounted by the plugin's `rio_cli` hook; each command imports what it needs when it runs.
"""

from __future__ import annotations

from typing import Annotated, Any

import typer

from rio.cli.args import known_station, not_empty, one_of, output_dir, positive, rate_hz

from .messages import DISTROS

app = typer.Typer(help="ROS 2 over zenoh (rmw_zenoh's wire format, no ROS installation): bridge a station.",
                  no_args_is_help=True)

Distro = Annotated[str, typer.Option("--distro", callback=one_of(*DISTROS),
                                     help=f"ROS 2 distribution of the peers: {', '.join(DISTROS)} (message "
                                          "definitions and type hashes; humble's rmw_zenoh sends no type hash).")]


@app.command()
def bridge(
    station: Annotated[str, typer.Argument(callback=known_station,
                                           help="Station name (`rio stations list`) or path of a .toml file.")],
    domain: Annotated[int, typer.Option("--domain", envvar="ROS_DOMAIN_ID", min=0, max=232,
                                        help="ROS domain id (default: $ROS_DOMAIN_ID, else 0).")] = 0,
    rate: Annotated[float, typer.Option("--rate", callback=rate_hz,
                                        help="Publishing rate (Hz, 1 to 10000); commands are applied at this rate "
                                             "too.")] = 30.0,
    connect: Annotated[list[str] | None, typer.Option(
        "--connect", callback=endpoints,
        help="zenoh endpoint to connect to, repeatable (default: the local rmw_zenoh router, tcp/127.0.0.1:7447; "
             "another machine's: tcp/HOST:7447).")] = None,
    listen: Annotated[list[str] | None, typer.Option(
        "--listen", callback=endpoints,
        help="zenoh endpoint to listen on, repeatable (default: tcp/127.0.0.1:0, loopback only).")] = None,
    namespace: Annotated[str, typer.Option("--namespace", help="Prefix of every topic but /tf (e.g. /lab1).")] = "",
    images: Annotated[str, typer.Option("--images", callback=one_of("raw", "compressed", "both"),
                                        help="Camera topics: raw (sensor_msgs/Image), compressed (JPEG), both.")]
    = "raw",
    read_only: Annotated[bool, typer.Option("--read-only", help="Publish only: take no command from ROS.")] = False,
    distro: Distro = "jazzy",
    middleware: Annotated[str | None, typer.Option("--middleware", "-m", callback=not_empty,
                                                   help="Override the station's middleware.")] = None,
    duration: Annotated[float | None, typer.Option("--duration", "-d", callback=positive,
                                                   help="Stop after this many seconds.")] = None,
    keys: Annotated[str | None, typer.Option("--keys", callback=not_empty,
                                             help="This machine's keys directory (`rio keys generate`): every link "
                                                  "is mutual TLS with the station's CA; needed for endpoints beyond "
                                                  "127.0.0.1 (or --insecure).")] = None,
    insecure: Annotated[bool, typer.Option("--insecure", help="Listen or connect beyond 127.0.0.1 without keys: "
                                                              "anyone who reaches the port can command the robot "
                                                              "(said at every start).")] = False,
) -> None:
    """Start STATION and publish it to ROS 2: joint states, end-effector poses, TF and camera images;
    follow joint trajectories and cmd_vel from ROS through each arm's own safety limits (Ctrl-C stops)."""
    from rio import clock
    from rio.loop.signals import StopSignals

    from .bridge import BridgeOptions
    from .rmw import DEFAULT_CONNECT, DEFAULT_LISTEN
    from .station import RosOptions, open_bridge

    try:
        options = BridgeOptions(rate_hz=rate, namespace=namespace, images=images, commands=not read_only)
    except ValueError as e:
        raise typer.BadParameter(str(e)) from None
    ros = RosOptions(domain=domain, distro=distro, connect=tuple(connect or DEFAULT_CONNECT),
                     listen=tuple(listen or DEFAULT_LISTEN), keys=keys, insecure=insecure, commands=not read_only)
    with StopSignals() as stop:
        with open_bridge(station, middleware=middleware, ros=ros, options=options) as running:
            node = running.bridge.ros
            typer.echo(f"ROS 2 node /{running.node_name} (domain {domain}, {distro}), zenoh {node.zid}: "
                       f"connecting to {', '.join(ros.connect)}, listening on {', '.join(ros.listen)}")
            for line in topic_lines(running.bridge):
                typer.echo(f"  {line}")
            typer.echo(f"bridging at {rate:g} Hz; stop with Ctrl-C")
            t_end = None if duration is None else clock.now() + duration
            running.run(lambda: stop.received is not None or (t_end is not None and clock.now() > t_end))
            dropped = running.bridge.drops.total()
        typer.echo("stopped" + (f" by {stop.received}" if stop.received else "")
                   + (f"; {dropped} malformed command(s) dropped" if dropped else ""))
    raise typer.Exit(stop.exit_code)


def topic_lines(bridge: Any) -> list[str]:
    from .rmw import Publisher

    return [f"{'pub' if isinstance(e, Publisher) else 'sub'} {e.topic}  [{e.msg_type}]" for e in bridge.ros.endpoints]


def endpoints(value: list[str] | None) -> list[str] | None:
    """zenoh endpoints look like PROTOCOL/ADDRESS (tcp/192.168.1.2:7447)."""
    for e in value or []:
        proto, sep, addr = e.partition("/")
        if not (proto and sep and addr):
            raise typer.BadParameter(f"'{e}' is not a zenoh endpoint like tcp/192.168.1.2:7447")
    return value


@app.command()
def definitions(
    directory: Annotated[str, typer.Argument(callback=output_dir, help="Where to write <pkg>/msg/<Type>.msg.")],
    distro: Distro = "jazzy",
) -> None:
    """Write the standard ROS 2 message definitions the bridge uses as .msg files (from rosbags' typestore,
    offline), e.g. for zenoh-ros2-sdk's registry (`get_registry().messages_dir = DIR`)."""
    from .messages import message_types, write_definitions

    root = write_definitions(directory, distro)
    typer.echo(f"{len(message_types(distro).store.fielddefs)} message definitions of ROS 2 {distro} in {root}")
