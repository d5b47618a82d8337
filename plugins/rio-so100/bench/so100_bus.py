"""How fast the SO-100 drivers talk to an (emulated) Feetech bus, with the raw pty as the reference.

    python plugins/rio-so100/bench/so100_bus.py [--seconds 2]

Rows, all over a pseudo-terminal and measured in this run:
  raw pty round trip     a thread answers each 14-byte request with 96 bytes (the size of a 6-servo
                         state-block SYNC READ) using bare os.read/os.write: the transport's ceiling
  sdk GroupSyncRead      the unmodified scservo_sdk (zero-timeout busy-wait reads) against FeetechBusEmulator
  FeetechBus.sync_read   our wrapper (error bytes, port lock, retries, blocking read slices)
  ServoGroup cycle       what the follower does per tick: sync read + decode + sync write of goals
  ... emulator in a subprocess  the same, with the emulated bus in its own process (no shared GIL),
                         closer to a real bus where the servos cost the host nothing
Each row gives cycles per second, the median and 99th percentile cycle time and CPU time per cycle
of this process. A real bus at 1 Mbaud adds ~1.3 ms of wire time per 6-servo sync read (plus the
USB adapter's latency), so these are the software costs, not a real arm's rate.
"""

from __future__ import annotations

import argparse
import os
import select
import subprocess
import sys
import threading
import time

import numpy as np


def measure(name: str, fn, seconds: float) -> None:
    fn()  # warm up (first packets build the SDK objects)
    times = []
    cpu0, t_end = time.process_time(), time.perf_counter() + seconds
    while True:
        t = time.perf_counter()
        if t > t_end:
            break
        fn()
        times.append(time.perf_counter() - t)
    cpu = (time.process_time() - cpu0) / len(times)
    ts = np.array(times) * 1e6
    print(f"{name:44s} {len(ts) / seconds:8.0f} /s   median {np.median(ts):6.0f} us   p99 "
          f"{np.percentile(ts, 99):6.0f} us   cpu {cpu * 1e6:5.0f} us/cycle")


def raw_pty(seconds: float) -> None:
    master, slave = os.openpty()
    import tty

    tty.setraw(slave)
    stop = threading.Event()
    reply = bytes(96)

    def serve():
        while not stop.is_set():
            if select.select([master], [], [], 0.05)[0]:
                os.read(master, 64)
                os.write(master, reply)

    th = threading.Thread(target=serve, daemon=True)
    th.start()
    request = bytes(14)

    def round_trip():
        os.write(slave, request)
        got = 0
        while got < len(reply):
            select.select([slave], [], [])
            got += len(os.read(slave, 256))

    measure("raw pty round trip (96 B reply)", round_trip, seconds)
    stop.set()
    th.join()
    os.close(master)
    os.close(slave)


def bus_rows(port: str, seconds: float, suffix: str = "") -> None:
    import scservo_sdk as scs
    from rio_so100.calibration import default_calibration
    from rio_so100.feetech import control_table as T
    from rio_so100.feetech.bus import FeetechBus
    from rio_so100.models import ARM_JOINTS, GRIPPER
    from rio_so100.servo_group import ServoGroup

    ph, pk = scs.PortHandler(port), scs.PacketHandler(0)
    ph.openPort()
    ph.setBaudRate(1_000_000)
    reader = scs.GroupSyncRead(ph, pk, *T.STATE_BLOCK)
    for sid in range(1, 7):
        reader.addParam(sid)

    def sdk_read():
        assert reader.txRxPacket() == scs.COMM_SUCCESS

    measure("sdk GroupSyncRead, 6 servos" + suffix, sdk_read, seconds)
    ph.closePort()

    cal = default_calibration("so100", "follower")
    joints = {n: cal.joint(n) for n in [*ARM_JOINTS, GRIPPER]}
    with FeetechBus(port) as bus:
        measure("FeetechBus.sync_read, 6 servos" + suffix, lambda: bus.sync_read(range(1, 7), *T.STATE_BLOCK),
                seconds)
        group = ServoGroup(bus, joints)
        q = np.zeros(6)

        def cycle():
            group.read()
            group.write_rad(q)

        measure("ServoGroup cycle (read+write)" + suffix, cycle, seconds)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0, help="per row")
    args = ap.parse_args()
    from rio_so100.emulator import FeetechBusEmulator

    print(f"python {sys.version.split()[0]}, {os.cpu_count()} cpus")
    raw_pty(args.seconds)
    with FeetechBusEmulator() as vb:
        bus_rows(vb.port, args.seconds)
    proc = subprocess.Popen([sys.executable, "-c", "from rio_so100.cli import app; app()", "emulator",
                             "--seconds", str(4 * args.seconds + 10)],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        port = proc.stdout.readline().strip()
        bus_rows(port, args.seconds, ", emulator in subprocess")
    finally:
        proc.terminate()
        proc.wait(5)


if __name__ == "__main__":
    main()
