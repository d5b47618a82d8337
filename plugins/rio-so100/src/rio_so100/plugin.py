"""rio-so100's plugin module (entry point group `rio`): drivers, packaged stations and the
`rio so100 ...` commands. Specs only: nothing here imports the Feetech SDK."""

from __future__ import annotations

from typing import Any

from rio.hookspecs import hookimpl
from rio.specs import Spec

_P = "rio_so100"


def _arm_specs(model: str) -> list[Spec]:
    cap = model.capitalize()                        # So100 / So101: class name prefix
    so101 = "So101" if model == "so101" else ""     # config models: FollowerConfig / So101FollowerConfig
    label = "SO-101" if model == "so101" else "SO-100"
    return [
        Spec(f"{model}.follower", "arm", f"{_P}.follower.driver:{cap}Follower",
             f"{label} follower arm joints (Feetech STS3215 bus, or port = \"virtual\")",
             config=f"{_P}.follower.config:{so101}FollowerConfig"),
        Spec(f"{model}.gripper", "gripper", f"{_P}.gripper.driver:{cap}Gripper",
             f"{label} jaw servo as a gripper (shares the follower's bus)",
             config=f"{_P}.gripper.config:{so101}GripperConfig"),
        Spec(f"{model}.leader", "teleop", f"{_P}.leader.driver:{cap}Leader",
             f"{label} leader arm (torque off), joint positions for leader-follower teleop",
             config=f"{_P}.leader.config:{so101}LeaderConfig"),
    ]


@hookimpl
def rio_drivers() -> list[Spec]:
    return _arm_specs("so100") + _arm_specs("so101")


_STATIONS = {
    "so100-virtual": "SO-100 follower + gripper + leader on virtual buses (no hardware; the leader waves)",
    "so100-bimanual-virtual": "two SO-100 followers + grippers + two leaders on virtual buses (ALOHA-style)",
    "so100-sim": "SO-100 drivers on virtual buses backed by rio-sim's MuJoCo arm, virtual leader (needs rio-sim)",
    "so100": "SO-100 follower + gripper + leader arm on serial ports (edit the ports)",
    "so100-bimanual": "two SO-100 followers + grippers + two leaders on serial ports (edit the ports)",
    "so101": "SO-101 follower + gripper + leader arm on serial ports (edit the ports)",
    "so101-bimanual": "two SO-101 followers + grippers + two leaders on serial ports (edit the ports)",
}


@hookimpl
def rio_stations() -> list[Spec]:
    return [Spec(name, "station", f"{_P}:stations/{name}.toml", text) for name, text in _STATIONS.items()]


@hookimpl
def rio_cli(app: Any) -> None:
    from .cli import app as so100

    app.add_typer(so100, name="so100")
