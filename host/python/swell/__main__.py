"""python3 -m swell: a few of swell-tool's commands on the Python library (it proves the library;
swell-tool is the console)."""
from __future__ import annotations

import argparse
import sys

from . import PARAMS, SwellError, check, connect
from .link import LinkError

EXIT = {"NoController": 3, "Timeout": 5, "Refused": 6, "UnknownParameter": 2, "BadValue": 2}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python3 -m swell", description="Talk to a running swell controller "
                                 "through the Python library. Exit status: 0 done, 1 link failure, 2 bad "
                                 "arguments or an unknown parameter, 3 no controller, 5 no answer, 6 refused, "
                                 "7 check: a link of the chain failed.")
    ap.add_argument("--link", default="udp:127.0.0.1:47802", help="udp[:PORT], udp:HOST:PORT, can:IFACE or "
                    "usb[:VID:PID] (default udp:127.0.0.1:47802, swell-ctl's clients' port)")
    ap.add_argument("--timeout", type=float, default=2.0, help="seconds to wait for an answer (default 2)")
    sub = ap.add_subparsers(dest="cmd", required=True)
    sub.add_parser("info", help="the controller's node, state, firmware, object and pool")
    sub.add_parser("params", help="every parameter's value in its unit")
    g = sub.add_parser("get", help="one parameter")
    g.add_argument("name")
    s = sub.add_parser("set", help="set a parameter (a number in its unit, or with a unit: 80g, '0.08 kg') and "
                       "print the value now in force")
    s.add_argument("name")
    s.add_argument("value", nargs="+")
    for name, what in (("run", "RUN: armed -> running"), ("stop", "STOP: running -> armed"),
                       ("clear", "CLEAR: fault -> idle")):
        sub.add_parser(name, help=what)
    w = sub.add_parser("watch", help="object pose and force samples for SECONDS, one line each")
    w.add_argument("seconds", type=float)
    r = sub.add_parser("record", help="record SECONDS of the controller's frames into FILE (SWELLREC)")
    r.add_argument("file")
    r.add_argument("seconds", type=float)
    k = sub.add_parser("check", help="swell-tool check: the chain before holding the handle, one line each "
                       "with the fix; exit 0 only when none fails")
    k.add_argument("--hm", metavar="HOST[:PORT]", help="ask the HapticMaster's own interface (read only)")
    k.add_argument("--max-force", type=float, default=2.0, metavar="N", help="force.max accepted (default 2)")
    k.add_argument("--max-rate", type=float, default=20.0, metavar="N/S", help="force.rate accepted (default 20)")
    k.add_argument("--max-rtt-ms", type=float, default=20.0, metavar="MS", help="round trip accepted (default 20)")
    a = ap.parse_args(argv)
    if a.cmd == "check":
        r = check(a.link, a.timeout, a.hm, a.max_force, a.max_rate, a.max_rtt_ms)
        print(r)
        return 0 if r.ok else 7
    try:
        with connect(a.link, a.timeout) as c:
            if a.cmd == "info":
                i = c.info
                print("node %d, %s, firmware %s, object %.1f x %.1f x %.1f mm, pool %d x %d cells of %.3f mm, "
                      "depth %.2f mm" % ((i.node, c.state, i.firmware) + i.object_mm + i.grid + (i.dx_mm, i.depth_mm)))
            elif a.cmd == "params":
                for name, p in PARAMS.items():
                    print("%-20s %14.6g %-6s%s" % (name, c.params[name], p.unit, " (read only)" if p.read_only else ""))
            elif a.cmd == "get":
                print("%s = %.9g %s" % (a.name, c.params[a.name], PARAMS[a.name].unit))
            elif a.cmd == "set":
                c.params[a.name] = " ".join(a.value)
                print("%s = %.9g %s" % (a.name, c.params[a.name], PARAMS[a.name].unit))
            elif a.cmd in ("run", "stop", "clear"):
                {"run": c.start, "stop": c.stop, "clear": c.reset}[a.cmd]()
                print("%s: done, state %s" % (a.cmd, c.state))
            elif a.cmd == "watch":
                with c.stream() as st:
                    arr = st.to_numpy(seconds=a.seconds, heights_hz=0)
                for row in arr.samples:
                    print("%8.3f s  z %8.2f mm  submerged %5.1f %%  fz %6.2f N" % (row["t"], row["z"],
                                                                                  row["submersion"], row["fz"]))
                print("%d samples, %d lost; %d packets, %d lost" % (len(arr), arr.lost_samples, arr.packets,
                                                                    arr.lost_packets))
            elif a.cmd == "record":
                n = c.record(a.file, a.seconds)
                print("%s: %d frames in %.1f s" % (a.file, n, a.seconds))
    except SwellError as e:
        print("python3 -m swell: %s" % e, file=sys.stderr)
        return EXIT.get(type(e).__name__, 1)
    except LinkError as e:
        print("python3 -m swell: %s" % e, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
