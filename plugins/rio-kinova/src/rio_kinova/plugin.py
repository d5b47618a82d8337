"""rio-kinova's plugin module (entry point group `rio`): drivers, packaged stations and the kortex_api
requirement. Specs only: nothing here imports kortex."""

from __future__ import annotations

from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec

from .models import ARMS, INSTALL

_P = "rio_kinova"


@hookimpl
def rio_drivers() -> list[Spec]:
    arms = [Spec(f"kinova.{m.name}", "arm", f"{_P}.arm.driver:KinovaArm",
                 f"Kinova {m.label} on its base (kortex_api: joint speeds, twists, or 1 kHz low-level servoing)",
                 preset={"model": m.name}) for m in ARMS.values()]
    grip = Spec("kinova.robotiq_2f85", "gripper", f"{_P}.gripper.robotiq:KinovaRobotiq",
                "Robotiq 2F-85 on a Gen3's interface module, through the base (kortex_api)")
    return [*arms, grip]


_STATIONS = {
    "gen3-robotiq": "Kinova Gen3 7-DOF + Robotiq 2F-85 on its base (edit the IP, user, password and camera serials)",
    "gen3-fake": "Kinova Gen3 7-DOF + Robotiq 2F-85 on the fake kortex backend (no hardware, no kortex_api)",
    "gen3-sim": "Kinova Gen3 7-DOF + 2F-85 on the fake kortex backend driving a rio-sim world (needs rio-sim)",
}


#: station names before the stand-ins got one word each (fake, emulator, sim): still loaded, with a notice
_FORMERLY = {"gen3-fake": ("gen3-virtual",)}


@hookimpl
def rio_stations() -> list[Spec]:
    return [Spec(name, "station", f"{_P}:stations/{name}.toml", text, formerly=_FORMERLY.get(name, ()))
            for name, text in _STATIONS.items()]


@hookimpl
def rio_requirements() -> list[Requirement]:
    return [Requirement("kortex_api", INSTALL, "every Kinova driver with backend = \"kortex\" (Kinova's kortex_api)"),
            Requirement("mink", "pip install 'rio-kinova[ik]'",
                        'eef_control = "ik" (the default; "native": the base\'s twists), '
                        "eef_pose from RIO's model (mink on MuJoCo)")]
