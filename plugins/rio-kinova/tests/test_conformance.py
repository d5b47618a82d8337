"""Every rio-kinova driver passes the conformance kit of its kind on the FAKE kortex backend: the
driver code is the real one, but kortex's client objects are stand-ins (`rio_kinova.fake`), because
kortex_api cannot run here (Kinova's own wheel, a proprietary protocol, no Gen3 on the test machine).
What these tests prove is the driver's use of the RIO contract and of kortex's call shapes, not kortex."""

from __future__ import annotations

import itertools

from rio.conformance.drivers import ArmConformance, GripperConformance

_ips = itertools.count(20)


class OnFake:
    model = "gen3"
    tracking_tol = 0.03
    # the real backend without kortex_api installed: open() fails, naming the wheel to install
    bad_config = {"backend": "kortex"}

    @property
    def config(self) -> dict:
        # a fresh fake base per case (sessions are shared per ip)
        return {"backend": "fake", "model": self.model, "ip": f"127.0.0.{next(_ips) % 250 + 2}"}


class TestGen3(OnFake, ArmConformance):
    driver = "kinova.gen3"


class TestGen3Lite(OnFake, ArmConformance):
    driver = "kinova.gen3_lite"
    model = "gen3_lite"


class TestGen3LowLevel(OnFake, ArmConformance):
    driver = "kinova.gen3_6dof"
    model = "gen3_6dof"

    @property
    def config(self) -> dict:
        return {**super().config, "low_level": True, "rate_hz": 500, "max_step_rad": 0.002}


class TestRobotiq2F85(OnFake, GripperConformance):
    driver = "kinova.robotiq_2f85"
