"""`unitree.g1` passes the humanoid conformance kit against the MuJoCo DDS bridge: the unmodified driver,
real DDS on loopback, the robot's own topics and CRC, physics behind them.

Config for the kit, and why: whole-body `lowcmd` (the kit commands every joint); joint limits narrowed to
0.4 rad around the bridge's start pose (the kit drives joints to their limits: small moves keep a case
short); gains stiff enough that gravity sags a joint of the hanging robot less than the kit's 0.03 rad
tracking tolerance (the real robot's defaults sag more: a controller adds feed-forward); strong damping,
since the kit re-enables a disabled, damped robot and wants it where it was. `on_stale` is the driver's
default, "damp": the kit's watchdog case asks the driver (`node.safety.damps_on_stale`) and checks the
damping stop (disabled with its stale_commands fault, driven no more, clear_faults() holding where it is)."""

from __future__ import annotations

import contextlib

from rio_unitree.g1 import HOME, JOINTS

from rio.conformance.drivers import HumanoidConformance

_START = [HOME.get(j.name, 0.0) for j in JOINTS]
_KD = [2.0 if "wrist" in j.name else 10.0 if j.slot >= 15 else 30.0 for j in JOINTS]  # about critical


class TestG1OnBridge(HumanoidConformance):
    driver = "unitree.g1"
    config = {
        "control": "lowcmd", "rate_hz": 100.0, "max_step_rad": 0.01, "state_timeout_s": 1.0,
        "kp": [400.0] * 29, "kd": _KD, "damping_kd": [3 * kd for kd in _KD],
        "joint_limits": [[max(j.lower, q - 0.4), min(j.upper, q + 0.4)] for j, q in zip(JOINTS, _START, strict=True)],
    }
    bad_config = {"interface": "nope0"}

    @contextlib.contextmanager
    def emulator(self):
        from rio_unitree.bridge import Bridge
        from rio_unitree.testing import free_domain_id

        domain = free_domain_id()
        with Bridge(domain_id=domain, interface="lo", model="fallback", state_rate_hz=250.0):
            yield {"interface": "lo", "domain_id": domain}

