"""What crossing a link costs a node: API round trips between two machines, emulated on one.

Two network namespaces joined by a veth pair (`rio.machine.netns`; Linux, root). On side A an EchoNode is
served the way `rio serve` serves a placed node (`Middleware.placed`: fixed ports on A's address); on
side B a client calls `echo(payload)` (2048 bytes, as the middleware benchmark) and, alternating in
the same process, a bare TCP echo server on A is pinged with the same payload: the floor any
transport over that link pays. Reported per middleware, with the station's keys (CURVE / mutual TLS)
and without (insecure): median one-way latency (RTT / 2) in microseconds, the node's ratio to the
bare TCP ping, the cost of the link (the same node with both ends on loopback in one namespace), and the
cost of authentication (keyed / insecure).

    sudo python bench/multi_machine.py [--n 2000] [--rounds 3] [--json]

`--scenario cameras`: the link at camera rates (`rio.benchmarks.link`): 3 x 640x480 RGB + 1 depth at 30 fps
from the robot's namespace to the workstation's over the veth shaped with `tc` netem, (a) 1 Gbit/s 0.2 ms
and (b) 100 Mbit/s 2 ms 0.1 % loss, raw and compressed (JPEG colour, zstd depth) in the same run: frame
age p50/p99, frames dropped, link utilisation, encode/decode CPU per frame. `--scenario requests`: a
500 Hz loop sending requests to four remote nodes over the same shaped links, with credits and with each
request waiting for its acknowledgement: tick lateness p99, send_request time.

    sudo python bench/multi_machine.py --scenario cameras [--seconds 10]
    sudo python bench/multi_machine.py --scenario requests [--seconds 5]

`--scenario send`: `send_request`'s own time on shm, zmq and zenoh in one loop on this machine
(`bench/send_request.py`: the issue's "within 3x of shm's in the same run"; no namespaces, no root).
A policy node across the link (obs -> first action, cameras on the robot, the policy on the workstation):
`bench/policy_link.py`.
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import struct
import subprocess
import sys
import tempfile
import time

import numpy as np

PAYLOAD = 2048
PORT, RAW_PORT = 7700, 7790


def _mw(name: str, keys: str | None):
    from rio.middleware.zenoh import ZenohMiddleware
    from rio.middleware.zmq import ZmqMiddleware

    cls = {"zmq": ZmqMiddleware, "zenoh": ZenohMiddleware}[name]
    opts = {"keys": keys} if keys else {"insecure": True}
    return cls(cls.Config(**opts), station="bench")


def _placed(name: str, keys: str | None, host: str):
    from rio.station.model import MachineSection

    mw = _mw(name, keys)
    options, address = mw.placed("echo", 0, "robot", MachineSection(address=host, nodes=["echo"], port=PORT))
    return mw, options, address


def serve(name: str, keys: str | None, host: str) -> None:
    """Side A: the EchoNode at its placed address until stdin closes."""
    from rio.runtime.manager import ServerManager
    from rio.runtime.manager import serve as served
    from rio.testing import EchoNode

    mw, options, _ = _placed(name, keys, host)
    with ServerManager([served(EchoNode, mw.with_options(**options), name="echo", payload_bytes=PAYLOAD)],
                       station="bench"):
        print("ready", flush=True)
        sys.stdin.read()


def raw_server(host: str) -> None:
    """Side A: a bare TCP echo of length-prefixed messages (the link's floor)."""
    srv = socket.create_server((host, RAW_PORT))
    print("ready", flush=True)
    conn, _ = srv.accept()
    conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    f = conn.makefile("rb")
    while True:
        head = f.read(4)
        if len(head) < 4:
            return
        body = f.read(struct.unpack("<I", head)[0])
        conn.sendall(head + body)


def client(name: str, keys: str | None, host: str, n: int, rounds: int) -> None:
    """Side B: alternate blocks of node calls and bare pings; print one JSON line of RTTs (s)."""
    from rio.benchmarks.middleware_latency import time_roundtrips
    from rio.runtime.manager import connect
    from rio.testing import EchoNode

    mw, _, address = _placed(name, keys, host)
    payload = np.zeros(PAYLOAD, np.uint8)
    sock = socket.create_connection((host, RAW_PORT))
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    f = sock.makefile("rb")
    frame = struct.pack("<I", PAYLOAD) + payload.tobytes()

    def ping(p: np.ndarray) -> np.ndarray:
        sock.sendall(frame)
        head = f.read(4)
        return np.frombuffer(f.read(struct.unpack("<I", head)[0]), np.uint8)

    node_rtts, raw_rtts = [], []
    with connect(EchoNode, mw, name="echo", station="bench", address=address, payload_bytes=PAYLOAD) as c:
        for _ in range(rounds):
            node_rtts.append(time_roundtrips(c.echo, payload, n, warmup=100))
            raw_rtts.append(time_roundtrips(ping, payload, n, warmup=100))
    print(json.dumps({"node": np.concatenate(node_rtts).tolist(), "raw": np.concatenate(raw_rtts).tolist()}))


def _child(side, *args: str, **kw) -> subprocess.Popen:  # noqa: ANN001 - a netns.Side
    return side.popen([sys.executable, __file__, *args], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                      **kw)


def _ready(proc: subprocess.Popen, what: str) -> None:
    line = proc.stdout.readline()
    if line.strip() != "ready":
        raise RuntimeError(f"{what} did not start (exit code {proc.poll()})")


def measure(net, name: str, keyed: bool, key_root: str, n: int, rounds: int, link: bool = True) -> dict:  # noqa: ANN001
    """Over the veth link (`link`), or both ends in B on loopback: the same node without the link."""
    a_keys = os.path.join(key_root, "robot") if keyed else None
    b_keys = os.path.join(key_root, "workstation") if keyed else None
    side, host = (net.a, net.a.address) if link else (net.b, "127.0.0.1")
    srv = _child(side, "--serve", name, "--host", host, *(["--keys", a_keys] if a_keys else []))
    raw = _child(side, "--raw-server", "--host", host)
    try:
        _ready(srv, f"{name} node")
        _ready(raw, "tcp echo")
        out = net.b.run([sys.executable, __file__, "--client", name, "--host", host, "--n", str(n),
                         "--rounds", str(rounds), *(["--keys", b_keys] if b_keys else [])],
                        capture_output=True, text=True, timeout=600)
        if out.returncode != 0:
            raise RuntimeError(out.stderr[-2000:])
        rtts = json.loads(out.stdout.strip().splitlines()[-1])
    finally:
        for p in (srv, raw):
            p.stdin.close()
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
    node_us = float(np.median(rtts["node"])) / 2 * 1e6
    raw_us = float(np.median(rtts["raw"])) / 2 * 1e6
    return {"middleware": name, "auth": "keys" if keyed else "insecure", "link": "veth" if link else "loopback",
            "half_rtt_us": round(node_us, 1),
            "p99_us": round(float(np.percentile(rtts["node"], 99)) / 2 * 1e6, 1),
            "raw_tcp_half_rtt_us": round(raw_us, 1), "ratio_to_raw": round(node_us / raw_us, 2)}


#: The shaped links: (label, tc rate, one-way delay ms, loss %).
LINKS = [("1gbit-0.2ms", "1gbit", 0.2, 0.0), ("100mbit-2ms-0.1%", "100mbit", 2.0, 0.1)]
_LINK_MBIT = {"1gbit": 1000.0, "100mbit": 100.0}


def _side(side, *args: str, **kw) -> subprocess.Popen:  # noqa: ANN001 - a netns.Side
    return side.popen([sys.executable, "-m", "rio.benchmarks.link", *args], stdin=subprocess.PIPE,
                      stdout=subprocess.PIPE, text=True, **kw)


def _run_side(side, *args: str, timeout: float) -> dict:  # noqa: ANN001 - a netns.Side
    out = side.run([sys.executable, "-m", "rio.benchmarks.link", *args], capture_output=True, text=True,
                   timeout=timeout)
    if out.returncode != 0:
        raise RuntimeError(out.stderr[-2000:])
    return json.loads(out.stdout.strip().splitlines()[-1])


def _stop(proc: subprocess.Popen) -> None:
    proc.stdin.close()
    try:
        proc.wait(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()


def cameras(net, seconds: float, which: str = "all") -> list[dict]:  # noqa: ANN001 - a netns.TwoMachines
    from rio.benchmarks.link import encode_cost

    rows = []
    cost = {codec: encode_cost(codec) for codec in ("raw", "auto")}
    for label, rate, delay, loss in LINKS:
        applied = net.shape(rate, delay, loss)
        print(f"[bench] link {label}: {applied}", file=sys.stderr, flush=True)
        for codec in ("raw", "auto"):
            print(f"[bench] cameras {'compressed' if codec == 'auto' else 'raw'} over {label} ...", file=sys.stderr,
                  flush=True)
            srv = _side(net.a, "serve-cameras", net.a.address, codec, which)
            try:
                _ready(srv, "cameras")
                got = _run_side(net.b, "read-cameras", net.a.address, codec, str(seconds), net.b.dev,
                                timeout=seconds + 120)
            finally:
                _stop(srv)
            cams = got["cameras"]
            rgb = [c for n, c in cams.items() if not n.startswith("depth")]
            extra = {"psnr_db": min(c["rgb_psnr_db"] for c in rgb), "depth_exact": cams["depth0"]["depth_exact"]}
            depth = cams["depth0"]
            rows.append({"link": label, "tc": applied, "cameras": list(cams), **extra,
                         "codec": "raw" if codec == "raw" else "jpeg+zstd",
                         "age_p50_ms": max(c["age_p50_ms"] or 0 for c in cams.values()),
                         "age_p99_ms": max(c["age_p99_ms"] or 0 for c in cams.values()),
                         "received": sum(c["received"] for c in cams.values()),
                         "dropped": sum(c["dropped"] for c in cams.values()),
                         "mbit_s": got["rx_mbit_s"], "utilisation": round(got["rx_mbit_s"] / _LINK_MBIT[rate], 3),
                         "rgb_kb": round(np.mean([c["bytes_per_frame"] for c in rgb]) / 1e3, 1),
                         "depth_kb": round(depth["bytes_per_frame"] / 1e3, 1),
                         "encode_ms": cost[codec],
                         "decode_ms": {"rgb": round(np.mean([c["decode_ms"] for c in rgb]), 2),
                                       "depth": depth["decode_ms"]}})
    net.shape()
    return rows


def requests(net, seconds: float) -> list[dict]:  # noqa: ANN001 - a netns.TwoMachines
    rows = []
    for label, rate, delay, loss in LINKS:
        applied = net.shape(rate, delay, loss)
        print(f"[bench] link {label}: {applied}", file=sys.stderr, flush=True)
        srv = _side(net.a, "serve-echoes", net.a.address)
        try:
            _ready(srv, "four nodes")
            for mode in ("credits", "acknowledged"):
                print(f"[bench] 500 Hz requests ({mode}) over {label} ...", file=sys.stderr, flush=True)
                got = _run_side(net.b, "request-loop", net.a.address, str(seconds), mode, timeout=seconds + 120)
                rows.append({"link": label, "tc": applied, **got})
        finally:
            _stop(srv)
    net.shape()
    return rows


def _print_links(rows: list[dict]) -> None:
    for label in dict.fromkeys(r["link"] for r in rows):
        print(f"link {label}: {next(r['tc'] for r in rows if r['link'] == label)}")


def _print_cameras(rows: list[dict]) -> None:
    _print_links(rows)
    print(f"cameras: {', '.join(rows[0]['cameras'])}; PSNR (dB) of the decoded colour frames, min: "
          f"{min(r['psnr_db'] for r in rows)}; depth exact after decoding: {all(r['depth_exact'] for r in rows)}")
    print(f"{'link':18} {'codec':9} {'age p50 ms':>10} {'age p99 ms':>10} {'recv':>5} {'dropped':>7} {'Mbit/s':>7} "
          f"{'util':>5} {'rgb kB':>7} {'depth kB':>8} {'enc ms rgb/depth':>16} {'dec ms rgb/depth':>16}")
    for r in rows:
        enc, dec = r["encode_ms"], r["decode_ms"]
        print(f"{r['link']:18} {r['codec']:9} {r['age_p50_ms']:10.1f} {r['age_p99_ms']:10.1f} {r['received']:5d} "
              f"{r['dropped']:7d} {r['mbit_s']:7.1f} {r['utilisation']:5.2f} {r['rgb_kb']:7.1f} {r['depth_kb']:8.1f} "
              f"{enc['rgb']:7.2f}/{enc['depth']:<8.2f} {dec['rgb']:7.2f}/{dec['depth']:<8.2f}")
    for label, *_ in LINKS:
        raw, coded = (next(r for r in rows if r["link"] == label and r["codec"] == c) for c in ("raw", "jpeg+zstd"))
        print(f"{label}: compressed/raw  age p99 x{coded['age_p99_ms'] / max(raw['age_p99_ms'], 1e-9):.3f}, "
              f"link use x{coded['mbit_s'] / max(raw['mbit_s'], 1e-9):.3f}, "
              f"dropped {coded['dropped']} vs {raw['dropped']}")


def _print_requests(rows: list[dict]) -> None:
    _print_links(rows)
    print("lateness: a tick's wake-up after its deadline; an overrun: a tick whose sends ran past the next deadline "
          "(the loop re-anchors, so lateness alone hides it)")
    print(f"{'link':18} {'mode':13} {'Hz':>6} {'overruns':>8} {'late p50 ms':>11} {'late p99 ms':>11} "
          f"{'send p50 us':>11} {'send p99 us':>11} {'sent':>6} {'no credit':>9} {'refused':>7}")
    for r in rows:
        print(f"{r['link']:18} {r['mode']:13} {r['achieved_hz']:6.1f} {r['overruns']:8d} {r['late_p50_ms']:11.3f} "
              f"{r['late_p99_ms']:11.3f} {r['send_p50_us']:11.1f} {r['send_p99_us']:11.1f} {r['sent']:6d} "
              f"{r['no_credits']:9d} {r['refused']:7d}")
    for label, *_ in LINKS:
        cr, ack = (next(r for r in rows if r["link"] == label and r["mode"] == m) for m in ("credits", "acknowledged"))
        print(f"{label}: acknowledged/credits  send p50 x{ack['send_p50_us'] / max(cr['send_p50_us'], 1e-9):.1f}, "
              f"send p99 x{ack['send_p99_us'] / max(cr['send_p99_us'], 1e-9):.1f}, "
              f"overruns {ack['overruns']} vs {cr['overruns']}, rate {ack['achieved_hz']} vs {cr['achieved_hz']} Hz")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=2000, help="timed round trips per block")
    p.add_argument("--rounds", type=int, default=3, help="alternating blocks of node calls and bare pings")
    p.add_argument("--middlewares", default="zmq,zenoh")
    p.add_argument("--json", action="store_true")
    p.add_argument("--scenario", choices=["latency", "cameras", "requests", "send"], default="latency")
    p.add_argument("--seconds", type=float, default=10.0, help="measured seconds per run (cameras, requests)")
    p.add_argument("--cameras", choices=["all", "pair"], default="all",
                   help="all: 3 RGB + 1 depth; pair: 1 RGB + 1 depth (a machine too loaded for four)")
    p.add_argument("--serve"), p.add_argument("--client"), p.add_argument("--raw-server", action="store_true")
    p.add_argument("--host"), p.add_argument("--keys")
    a = p.parse_args(argv)
    if a.serve:
        serve(a.serve, a.keys, a.host)
        return 0
    if a.raw_server:
        raw_server(a.host)
        return 0
    if a.client:
        client(a.client, a.keys, a.host, a.n, a.rounds)
        return 0
    if a.scenario == "send":
        from send_request import main as send_main  # bench/ is this script's directory

        return send_main(["--seconds", str(a.seconds), *(["--json"] if a.json else [])])

    from rio.machine import keys, netns

    why = netns.available()
    if why:
        print(f"cannot emulate two machines here: {why}", file=sys.stderr)
        return 2
    if a.scenario != "latency":
        why = netns.TC.missing()
        if why:
            print(f"cannot shape the link: {why}", file=sys.stderr)
            return 2
        with netns.TwoMachines() as net:
            rows = cameras(net, a.seconds, a.cameras) if a.scenario == "cameras" else requests(net, a.seconds)
        if a.json:
            print(json.dumps(rows, indent=2))
        else:
            (_print_cameras if a.scenario == "cameras" else _print_requests)(rows)
        return 0
    rows = []
    with tempfile.TemporaryDirectory(prefix="rio-mm-") as tmp, netns.TwoMachines() as net:
        keys.generate(os.path.join(tmp, "k"), ["robot", "workstation"])
        for name in a.middlewares.split(","):
            for keyed, link in ((False, False), (False, True), (True, True)):
                print(f"[bench] {name} {'with keys' if keyed else 'insecure'} over "
                      f"{'the veth link' if link else 'loopback'} ...", file=sys.stderr, flush=True)
                t0 = time.monotonic()
                rows.append(measure(net, name, keyed, os.path.join(tmp, "k"), a.n, a.rounds, link))
                print(f"[bench]   {time.monotonic() - t0:.0f} s", file=sys.stderr, flush=True)
    for name in a.middlewares.split(","):
        mine = [r for r in rows if r["middleware"] == name]
        local, ins, key = mine
        ins["link_cost"] = round(ins["half_rtt_us"] / local["half_rtt_us"], 2)
        key["auth_cost"] = round(key["half_rtt_us"] / ins["half_rtt_us"], 2)
    if a.json:
        print(json.dumps(rows, indent=2))
        return 0
    print(f"{'middleware':10} {'auth':9} {'link':9} {'one-way us':>10} {'p99 us':>8} {'bare TCP us':>11} "
          f"{'node/TCP':>8} {'veth/loopback':>13} {'keys/insecure':>13}")
    for r in rows:
        print(f"{r['middleware']:10} {r['auth']:9} {r['link']:9} {r['half_rtt_us']:10.1f} {r['p99_us']:8.1f} "
              f"{r['raw_tcp_half_rtt_us']:11.1f} {r['ratio_to_raw']:8.2f} {r.get('link_cost', ''):>13} "
              f"{r.get('auth_cost', ''):>13}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
