"""Every rio-franka driver passes the conformance kit of its kind on the fake franky backend.

libfranka's 1 kHz UDP link cannot reasonably be emulated, so these run on `rio_franka.fake`: franky's
own motion objects, exceptions and messages, a modelled control box (see fake.py). The hook makes a
fresh fake box per case."""

from __future__ import annotations

import itertools
from contextlib import contextmanager

from rio.conformance.drivers import ArmConformance, GripperConformance

_N = itertools.count(1)


class OnFake:
    fields: dict = {}
    bad_config = {"ip": "10.78.0.250", "backend": "nope"}

    @contextmanager
    def emulator(self):
        from rio_franka import fake

        ip = f"10.78.0.{next(_N)}"
        try:
            yield {"ip": ip, "backend": "fake", **self.fields}
        finally:
            fake.forget(ip)


class TestFR3(OnFake, ArmConformance):
    driver = "franka.fr3"
    fields = {"relative_dynamics_factor": 1.0}


class TestPanda(OnFake, ArmConformance):
    driver = "franka.panda"
    fields = {"relative_dynamics_factor": 1.0}


class TestFrankaHand(OnFake, GripperConformance):
    driver = "franka.hand"
