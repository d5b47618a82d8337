"""Unitree's own SDK, unmodified, against the bridge: its ChannelFactory, subscriber and publisher (in a
child process: the SDK's factory binds a whole process to one domain) read our rt/lowstate with a CRC
its `CRC().Crc()` accepts, and its rt/lowcmd, signed by that same function, moves the simulated elbow.
What the driver's wire format is checked against, end to end."""

from __future__ import annotations

import subprocess
import sys

from rio.testing import wait_until

SDK_CLIENT = """
import sys, time
from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher, ChannelSubscriber
from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowCmd_
from unitree_sdk2py.idl.unitree_hg.msg.dds_ import LowCmd_, LowState_
from unitree_sdk2py.utils.crc import CRC

ChannelFactoryInitialize(int(sys.argv[1]), "lo")
sub = ChannelSubscriber("rt/lowstate", LowState_)
sub.Init()
msg, t_end = None, time.time() + 10
while msg is None and time.time() < t_end:
    msg = sub.Read(0.5)
assert msg is not None, "no rt/lowstate"
assert CRC().Crc(msg) == msg.crc, "the lowstate CRC is not the SDK's"
print("lowstate", msg.mode_machine, msg.imu_state.quaternion, flush=True)
pub = ChannelPublisher("rt/lowcmd", LowCmd_)
pub.Init()
cmd = unitree_hg_msg_dds__LowCmd_()
cmd.mode_machine = msg.mode_machine
for i in range(29):
    m = cmd.motor_cmd[i]
    m.mode, m.q, m.kp, m.kd = 1, msg.motor_state[i].q, 150.0, 4.0
cmd.motor_cmd[18].q = 0.3  # left elbow
cmd.crc = CRC().Crc(cmd)
for _ in range(150):
    pub.Write(cmd)
    time.sleep(0.01)
print("sent", flush=True)
"""


def test_unitrees_sdk_reads_the_bridge_and_drives_it(make_bridge, domain_id):
    bridge = make_bridge()
    proc = subprocess.run([sys.executable, "-c", SDK_CLIENT, str(domain_id)], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "lowstate 5 [1.0, 0.0, 0.0, 0.0]" in proc.stdout and "sent" in proc.stdout
    assert bridge.counts.lowcmd >= 50 and bridge.counts.bad_crc == 0
    assert wait_until(lambda: abs(bridge.joint_pos()[18] - 0.3) < 0.05, timeout=3.0)


SDK_MOTION_SWITCHER = """
import sys
from unitree_sdk2py.core.channel import ChannelFactoryInitialize
from unitree_sdk2py.comm.motion_switcher.motion_switcher_client import MotionSwitcherClient

ChannelFactoryInitialize(int(sys.argv[1]), "lo")
msc = MotionSwitcherClient()
msc.SetTimeout(5.0)
msc.Init()
code, result = msc.CheckMode()
print("check", code, result["name"], flush=True)
code, _ = msc.ReleaseMode()
code2, result = msc.CheckMode()
print("released", code, code2, repr(result["name"]), flush=True)
"""


def test_unitrees_motion_switcher_client_releases_the_bridge(make_bridge, domain_id):
    """The RPC the bridge answers (and `rio unitree debug-mode` speaks) is the SDK's own."""
    bridge = make_bridge()
    proc = subprocess.run([sys.executable, "-c", SDK_MOTION_SWITCHER, str(domain_id)], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "check 0 ai" in proc.stdout and "released 0 0 ''" in proc.stdout, proc.stdout
    assert bridge.released
