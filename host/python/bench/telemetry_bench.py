#!/usr/bin/python3
"""telemetry_bench: swell for Python taking the controller's telemetry at its tick rate into numpy.

usage: tools/py host/python/bench/telemetry_bench.py [--bin DIR] [--seconds S] [--max-loss-pct P]

Starts swell-ctl (2500 Hz, software in the loop) and swell-hm (the object dropped into the pool, so
the water moves and heights go out every tick), waits until the object floats, then takes S seconds
(default 10) of telemetry with Stream.to_numpy. Lost packets are counted by the packet sequence
numbers the controller sent (a gap of a whole wrap of the 8-bit counter told by the poses between);
lost samples by the poses' own sequence numbers. Prints one block of figures (tools/docs/gen-benchmarks
takes it into docs/benchmarks.md). Exit 0 when at most P % (default 0.1) of the packets were lost, 1
otherwise, 2 bad arguments or a loop that did not start."""
import argparse
import os
import socket
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

import swell  # noqa: E402
from swell import bulk, proto  # noqa: E402


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def per_message_cost(fr: bulk.Frames, n: int = 2000) -> float:
    """Microseconds a packet of this capture costs decoded a message at a time (proto.py), for scale."""
    n = min(n, len(fr))
    t0 = time.perf_counter()
    for i in range(n):
        try:
            proto.packet_decode(fr.data[i, :fr.length[i]].tobytes())
        except proto.ProtocolError:
            pass
    return (time.perf_counter() - t0) / max(n, 1) * 1e6


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", default=os.path.join(HERE, "..", "..", "..", "build", "bin"),
                    help="the Release programs (default build/bin)")
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--max-loss-pct", type=float, default=0.1)
    a = ap.parse_args()
    if a.seconds <= 0:
        print("telemetry_bench: --seconds must be above 0", file=sys.stderr)
        return 2
    work = tempfile.mkdtemp(prefix="swell-pybench-")
    dev, view, clients = free_udp_port(), free_udp_port(), free_udp_port()
    ctl = subprocess.Popen([os.path.join(a.bin, "swell-ctl"), "--autorun", "--quiet", "--no-rt", "--silent-ticks",
                            "25", "--device", "udp:%d" % dev, "--host", "udp:%d,listen=127.0.0.1:%d" % (view, clients)],
                           stdout=open(os.path.join(work, "ctl.txt"), "w"), stderr=subprocess.STDOUT)
    time.sleep(0.3)
    hm = subprocess.Popen([os.path.join(a.bin, "swell-hm"), "--quiet", "--watchdog", "25", "--port", str(dev),
                           "--hand", "drop:z=20,hold=0.5", "--seconds", str(a.seconds + 30)],
                          stdout=open(os.path.join(work, "hm.txt"), "w"), stderr=subprocess.STDOUT)
    try:
        c = swell.connect("udp:127.0.0.1:%d" % clients, timeout=5.0)
        with c:
            c.wait_state("running", 10.0)
            time.sleep(1.5)  # the hand lets go at 0.5 s: the water moves
            tick = c.params["ctl.tick_hz"]
            with c.stream() as s:
                t0 = time.perf_counter()
                fr_before = time.process_time()
                tel = s.to_numpy(seconds=a.seconds)
                wall = time.perf_counter() - t0
                cpu = time.process_time() - fr_before
                # the same capture's cost split: receiving (fill) and decoding in bulk
                fr = c.capture(1.0)
                d0 = time.perf_counter()
                bulk.decode(fr, c.link.carrier)
                bulk_us = (time.perf_counter() - d0) / max(len(fr), 1) * 1e6
                one_us = per_message_cost(fr)
            rcvbuf = c.link.rcvbuf
    except swell.SwellError as e:
        print("telemetry_bench: %s" % e, file=sys.stderr)
        return 2
    finally:
        for p in (hm, ctl):
            p.terminate()
            try:
                p.wait(timeout=5)
            except subprocess.TimeoutExpired:
                p.kill()
    sent = tel.packets + tel.lost_packets
    loss_pct = 100.0 * tel.loss
    rate = sent / a.seconds
    print("== python telemetry: swell for Python, Stream.to_numpy over %.0f s, controller at %d Hz" % (a.seconds, tick))
    print("packets         %d sent, %d received, %d lost (%.3f %%), %.0f a second (%.2f a tick)"
          % (sent, tel.packets, tel.lost_packets, loss_pct, rate, rate / tick))
    print("samples         %d (%.0f a second), %d lost by their seq; %d height snapshots of %d x %d"
          % (len(tel), len(tel) / a.seconds, tel.lost_samples, len(tel.heights), tel.heights.shape[2],
             tel.heights.shape[1]))
    print("refused         %d frames" % tel.refused)
    print("socket buffer   %d bytes (SO_RCVBUF as granted)" % rcvbuf)
    print("cost            %.1f s of CPU for %.1f s (%.0f %% of a core): receiving and the bulk decode at the end"
          % (cpu, wall, 100.0 * cpu / wall))
    print("decode          a packet: %.1f us in bulk (numpy), %.1f us a message at a time (proto.py); %.0f %% and %.0f %% "
          "of a core at this rate" % (bulk_us, one_us, bulk_us * rate / 1e4, one_us * rate / 1e4))
    ok = loss_pct <= a.max_loss_pct
    print("result          %s: %.3f %% lost, at most %.3g %% allowed" % ("ok" if ok else "FAIL", loss_pct,
                                                                       a.max_loss_pct))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
