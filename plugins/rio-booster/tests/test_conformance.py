"""`booster.t1` passes the humanoid conformance kit against the emulated T1 (`rio_booster.emulator`: an
SDK-object fake with the SDK's own command types, not its DDS transport; see test_driver.py for why).

Config for the kit, and why: `on_stale` is the driver's default, "damp" (the kit's watchdog case asks the
driver, `damps_on_stale`, and checks the damping stop; test_driver.py checks the wire); `prepare_s = 0`
(the kit enables many times); joint limits narrowed to 0.4 rad around the emulator's start pose (the kit
drives joints to their limits: small moves keep a case short); stiff, well-damped gains so the emulated
joints settle within the kit's tracking tolerance."""

from __future__ import annotations

import contextlib
import itertools

from rio_booster.t1 import JOINTS, home_pose

from rio.conformance.drivers import HumanoidConformance

_START = home_pose()
_domains = itertools.cycle(range(150, 233))


class TestT1OnEmulator(HumanoidConformance):
    driver = "booster.t1"
    config = {
        "sdk": "rio_booster.emulator", "rate_hz": 100.0, "max_step_rad": 0.01, "prepare_s": 0.0,
        "state_timeout_s": 1.0,
        "kp": [150.0] * 23, "kd": [6.0 if "Head" not in j.name and "Ankle" not in j.name else 1.5 for j in JOINTS],
        "joint_limits": [[max(j.lower, q - 0.4), min(j.upper, q + 0.4)] for j, q in zip(JOINTS, _START, strict=True)],
    }
    bad_config = {"sdk": "rio_booster.no_such_sdk"}

    @contextlib.contextmanager
    def emulator(self):
        from rio_booster.emulator import EmulatedT1

        domain = next(_domains)
        with EmulatedT1(domain_id=domain, rate_hz=250.0):
            yield {"domain_id": domain}
