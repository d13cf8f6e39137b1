"""swell-tool check in Python: the chain from this computer to the handle, one line a link of it,
each failure with its fix (docs/first-contact.md). The same checks in the same order, with the same
thresholds, options, verdicts ("ok", "FAIL", "skip") and texts as host/tool/tool_check.c: the host
link, the controller (protocol, firmware, state), the device (heard, its rate, status), the round trip
of a request, the frame (where the handle is in the pool), the force limits (at most the first-run
2 N and 20 N/s unless told otherwise), and with hm (a HapticMaster's own TCP interface, read only)
its calibration, e-stop and swell's effects left on it."""
from __future__ import annotations

import socket
import struct
import time
from dataclasses import dataclass, field
from typing import List, Optional, Tuple

from . import _tables as T
from . import proto
from .client import PARAMS, Controller, NoController, Refused, SwellError, connect
from .link import LinkError

FORCE_N, RATE_N_S, RTT_MS = 2.0, 20.0, 20.0  # the first-run limits, swell-tool's defaults
HM_PORT = 7654
HM_TEXT_MAX = 1024
DEV_POWERED, DEV_FORCE_ON, DEV_ESTOP, DEV_FAULT = 1, 2, 4, 8  # dev.status bits
NAMES = ("link", "controller", "device", "round trip", "frame", "force", "calibration", "e-stop", "effects")


@dataclass
class Options:
    link: str  # the link as the C tools describe it, for the messages
    hm: Optional[str] = None  # HOST[:PORT] of the HapticMaster's TCP interface
    max_force_N: float = FORCE_N
    max_rate_N_s: float = RATE_N_S
    max_rtt_ms: float = RTT_MS
    timeout_ms: int = 1000


@dataclass
class Line:
    """One check's verdict ("ok", "FAIL", "skip"), name and text (a FAIL's ends in "fix: ...")."""
    verdict: str
    name: str
    text: str

    @property
    def fix(self) -> str:
        """A FAIL's fix, the words after "fix: "; "" for the others."""
        return self.text.split("fix: ", 1)[1] if "fix: " in self.text else ""

    def __str__(self) -> str:
        return "%-5s %-11s %s" % (self.verdict, self.name, self.text)


@dataclass
class CheckResult:
    """The lines in swell-tool check's order; ok when none failed (swell-tool's exit 0, else 7)."""
    lines: List[Line] = field(default_factory=list)

    def add(self, verdict: str, name: str, text: str) -> None:
        self.lines.append(Line(verdict, name, text))

    @property
    def ok(self) -> bool:
        return not self.failed

    @property
    def passed(self) -> List[Line]:
        return [x for x in self.lines if x.verdict == "ok"]

    @property
    def failed(self) -> List[Line]:
        return [x for x in self.lines if x.verdict == "FAIL"]

    @property
    def skipped(self) -> List[Line]:
        return [x for x in self.lines if x.verdict == "skip"]

    def __getitem__(self, name: str) -> Line:
        return next(x for x in self.lines if x.name == name)

    def summary(self) -> str:
        return "check: %d passed, %d failed, %d skipped" % (len(self.passed), len(self.failed), len(self.skipped))

    def __str__(self) -> str:
        return "\n".join([str(x) for x in self.lines] + [self.summary()])


def hm_ask(spec: str, request: str, timeout_ms: int) -> str:
    """One request on a HapticMaster's TCP interface (framing: the text's length as a 32-bit big-endian
    number, four zero bytes, the text) and its answer's text; OSError with a one-line reason."""
    host, _, port_s = spec.rpartition(":") if ":" in spec else (spec, "", "")
    if not host:
        host, port_s = spec, ""
    try:
        port = int(port_s) if port_s else HM_PORT
        if not 1 <= port <= 65535 or not host or len(host) >= 64:
            raise ValueError
    except ValueError:
        raise OSError("--hm %s: want HOST[:PORT]" % spec) from None
    try:
        addr = socket.gethostbyname(host)
    except OSError:
        raise OSError("cannot resolve '%s'" % host) from None
    end = time.monotonic() + timeout_ms / 1000.0
    try:
        so = socket.create_connection((addr, port), timeout=timeout_ms / 1000.0)
    except OSError:
        raise OSError("no answer on tcp %s:%d (connection refused)" % (host, port)) from None
    with so:
        so.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        text = request.encode()
        so.sendall(struct.pack(">II", len(text), 0) + text)
        buf = b""
        while True:
            if len(buf) >= 8:
                n, pad = struct.unpack(">II", buf[:8])
                if n == 0 or n > HM_TEXT_MAX or pad:
                    raise OSError("tcp %s:%d: an answer that is not the HapticMaster's framing" % (host, port))
                if len(buf) >= 8 + n:
                    return buf[8:8 + n].decode("utf-8", "replace")
            left = end - time.monotonic()
            if left <= 0:
                raise OSError("tcp %s:%d: no answer within %d ms" % (host, port, timeout_ms))
            so.settimeout(left)
            try:
                got = so.recv(4096)
            except socket.timeout:
                raise OSError("tcp %s:%d: no answer within %d ms" % (host, port, timeout_ms)) from None
            if not got:
                raise OSError("tcp %s:%d: the connection closed" % (host, port))
            buf += got


def answer_part(text: str, i: int) -> str:
    """Part i of a ';'-separated answer, spaces and quotes trimmed; "" when there is none."""
    parts = text.split(";")
    return parts[i].strip(' "') if i < len(parts) else ""


def _param(c: Controller, name: str) -> Tuple[int, int, str]:
    """(0, raw, "") read; (1, 0, why) the controller does not know it; (-1, 0, why) the request failed."""
    p = PARAMS.get(name)
    if p is None:
        return 1, 0, "this swell for Python has no parameter %s" % name
    try:
        return 0, c.request(False, p.id, 0, "get %s" % name), ""
    except Refused as e:
        if e.error == 9:  # unknown identifier: an older controller
            return 1, 0, e.reason
        return -1, 0, "refused: %s" % e.reason
    except SwellError as e:
        return -1, 0, str(e)


FX_NAMES = ("swell_bias", "swell_pull", "swell_push", "swell_damp", "swell_weight")


def _effects(r: CheckResult, o: Options, state: int) -> None:
    req = ";".join("get %s enabled" % n for n in FX_NAMES)
    try:
        ans = hm_ask(o.hm, req, o.timeout_ms)
    except OSError as e:
        r.add("FAIL", "effects", "cannot ask the device (%s): fix: check --hm HOST[:PORT], the device's own "
              "interface (port 7654)" % e)
        return
    left = ", ".join(n for k, n in enumerate(FX_NAMES) if answer_part(ans, k) == "true")
    if state == 3:
        r.add("ok", "effects", "swell's effects on the device while the force law runs: %s" % (left or "none"))
    elif not left:
        r.add("ok", "effects", "none of swell's effects enabled on the device")
    elif left == "swell_bias":
        f = ""
        try:
            f = answer_part(hm_ask(o.hm, "get swell_bias force", o.timeout_ms), 0)
        except OSError:
            pass
        if f == "[0,0,0]":
            r.add("ok", "effects", "swell_bias enabled with zero force (the stream mode's, between runs)")
        else:
            r.add("FAIL", "effects", "swell_bias left with a force (%s) while the force law is off: fix: restart "
                  "swell-ctl (its start-up and exit remove swell's effects) or 'remove swell_bias' on the device" % f)
    else:
        r.add("FAIL", "effects", "left enabled on the device while the force law is off: %s (the effect mode's "
              "springs stay on after a lost connection): fix: restart swell-ctl or swell-hmbridge (their start-up "
              "and exit remove them), or 'remove all' on the device, before holding the handle" % left)


def run(c: Controller, o: Options) -> CheckResult:
    """Every check on a connected controller, in swell-tool check's order."""
    r = CheckResult()
    r.add("ok", "link", "controller node %d heard on %s" % (c.node, o.link))
    c.wait_full(1.1 * o.timeout_ms / 1000.0 + 1.2)  # scene and info come at 1 Hz
    c._pump(0.06)  # a pose (100 Hz)
    hb = c.heartbeat
    state = hb["state"]
    i = c.latest.get("CTL_INFO")
    fw = "%d.%d.%d" % (i["fw_major"], i["fw_minor"], i["fw_patch"]) if i else "?"

    # controller: the protocol this library speaks, its firmware, its state
    if hb["version"] != T.PROTO_VERSION:
        r.add("FAIL", "controller", "protocol version %d, this swell-tool speaks %d: fix: the same swell release on "
              "both sides (swell-flash the image, or this tool's build)" % (hb["version"], T.PROTO_VERSION))
    elif state == 4:
        r.add("FAIL", "controller", "firmware %s, state fault (last error: %s): fix: remove the cause (below), then "
              "swell-tool clear" % (fw, proto.error_text(hb["err"])))
    elif state == 0:
        r.add("FAIL", "controller", "firmware %s, still booting: fix: wait a second and check again" % fw)
    else:
        r.add("ok", "controller", "protocol %d, firmware %s, state %s" % (hb["version"], fw, proto.state_name(state)))

    # device: heard (the controller leaves IDLE once it is; in FAULT its rate tells), rate, status
    st = rate = tick = mode = 0
    rc, st, err = _param(c, "dev.status")
    have_status = rc == 0
    if rc == 0:
        rc, rate, err = _param(c, "dev.rate")
    if rc == 0:
        rc, tick, err = _param(c, "ctl.tick_hz")
    if rc == 0:
        rc, mode, err = _param(c, "force.mode")
    heard = state in (2, 3) or (state == 4 and rc == 0 and rate > 0)
    sn = proto.state_name(state)
    if rc < 0:
        r.add("FAIL", "device", "cannot read its status: %s" % err)
        have_status = False
    elif not heard:
        r.add("FAIL", "device", "not heard (state %s): fix: the device link: swell-ctl --device (hm:HOST for a "
              "HapticMaster, its address and port 7654), CAN wiring and termination (about 60 ohm from CANH to "
              "CANL, power off), swell-hmbridge running, the device powered" % sn)
    elif rc == 1:
        r.add("ok", "device", "heard (state %s); rate and status not reported by this controller" % sn)
    elif rate * (20 if mode else 2) < tick:  # stream: every tick; effect: once an update, 1/10 of them
        r.add("FAIL", "device", "heard at %d Hz, the controller ticks at %d Hz: fix: a slow or lossy device link "
              "(swell-ctl's report counts lost samples; hm: round trips above a tick)" % (rate, tick))
    elif not st & DEV_POWERED or st & DEV_FAULT:
        r.add("FAIL", "device", "heard at %d Hz but not ready (status 0x%x: not powered, not in its force state or "
              "in fault): fix: power the device; hm: swell-ctl's log says why its start-up stopped" % (rate, st))
    else:
        r.add("ok", "device", "heard at %d Hz (tick %d Hz), status 0x%x (powered%s)"
              % (rate, tick, st, ", force on" if st & DEV_FORCE_ON else ""))

    # round trip: the fastest of five parameter reads
    best, worst, n, why = 1e9, 0.0, 0, ""
    for _ in range(5):
        c._pump(0)  # what waits is taken in first, as swell-tool's reads do
        t0 = time.monotonic()
        try:
            c.request(False, PARAMS["force.max"].id, 0, "get force.max")
        except SwellError as e:
            why = str(e)
            continue
        ms = (time.monotonic() - t0) * 1e3
        best, worst, n = min(best, ms), max(worst, ms), n + 1
    if n == 0:
        r.add("FAIL", "round trip", "no answer to a parameter read: %s" % why)
    elif best > o.max_rtt_ms:
        r.add("FAIL", "round trip", "%.2f ms at best (%.2f ms worst), above %.2f ms: fix: a busy or slow host link "
              "(another client flooding it, a CAN bus near full: swell-tool watch shows the load)"
              % (best, worst, o.max_rtt_ms))
    else:
        r.add("ok", "round trip", "%.2f ms at best, %.2f ms worst of %d" % (best, worst, n))

    # frame: the handle's place in the pool, from the device's position through the controller's frame
    fp = ("frame.x0", "frame.y0", "frame.z0", "frame.scale", "frame.axes", "frame.flip", "dev.x", "dev.y", "dev.z")
    f, bad = [], False
    for name in fp:
        rc_f, v, _ = _param(c, name)
        if rc_f != 0:
            bad = True
            break
        f.append(v)
    scene = c.latest.get("SCENE")
    if not heard or bad or scene is None:
        r.add("skip", "frame", "no device heard" if not heard else "no frame from this controller" if bad
              else "no scene heard yet")
    else:
        axis = (f[4] // 100 - 1, f[4] // 10 % 10 - 1, f[4] % 10 - 1)
        lx, ly = scene["nx"] * scene["dx_um"] * 1e-3, scene["ny"] * scene["dx_um"] * 1e-3
        pool = [f[k] * 1e-3 + (-1.0 if f[5] >> k & 1 else 1.0) * (f[3] / 65536.0)
                * (f[6 + axis[k]] * 1e-3 if 0 <= axis[k] < 3 else 0.0) for k in range(3)]
        dev = (f[6] * 1e-3, f[7] * 1e-3, f[8] * 1e-3)
        if pool[0] < 0 or pool[0] > lx or pool[1] < 0 or pool[1] > ly:
            r.add("FAIL", "frame", "the handle (device %.1f, %.1f, %.1f mm) is at pool x %.1f, y %.1f mm, outside the "
                  "pool's 0..%.0f x 0..%.0f mm: fix: move the handle over the water, or place the pool in the "
                  "device's workspace with frame.x0 / frame.y0 / frame.axes (docs/frame.md)"
                  % (dev + (pool[0], pool[1], lx, ly)))
        else:
            r.add("ok", "frame", "the handle (device %.1f, %.1f, %.1f mm) is at pool x %.1f, y %.1f, z %+.1f mm "
                  "(pool 0..%.0f x 0..%.0f mm, z 0 the rest level)" % (dev + tuple(pool) + (lx, ly)))

    # force limits: at most the first-run ones unless told otherwise
    rc1, fmax, err1 = _param(c, "force.max")
    rc2, frate, err2 = _param(c, "force.rate") if rc1 == 0 else (rc1, 0, err1)
    if rc1 != 0 or rc2 != 0:
        r.add("FAIL", "force", "cannot read the limits: %s" % (err1 or err2))
    elif fmax * 1e-6 > o.max_force_N + 1e-9 or frate * 1e-6 > o.max_rate_N_s + 1e-9:
        r.add("FAIL", "force", "force.max %s N, force.rate %s N/s, above %s N, %s N/s: fix: for a first contact "
              "swell-tool set force.max %sN and set force.rate %sN/s; to accept more on purpose, check --max-force N "
              "--max-rate N/s" % (_g3(fmax * 1e-6), _g3(frate * 1e-6), _g3(o.max_force_N), _g3(o.max_rate_N_s),
                                  _g(o.max_force_N), _g(o.max_rate_N_s)))
    else:
        r.add("ok", "force", "force.max %s N, force.rate %s N/s (at most %s N, %s N/s)"
              % (_g3(fmax * 1e-6), _g3(frate * 1e-6), _g3(o.max_force_N), _g3(o.max_rate_N_s)))

    # e-stop: the device's own (hm), else its status bit, else the controller's fault
    pushed = -1
    hm_err = ""
    if o.hm:
        try:
            ans = hm_ask(o.hm, "get emergencybuttonpushed;get position_calibrated;get force_calibrated", o.timeout_ms)
            pc, fc = answer_part(ans, 1), answer_part(ans, 2)
            pushed = 1 if answer_part(ans, 0) == "true" else 0
            if pc != "true" or fc != "true":
                r.add("FAIL", "calibration", "the device reports position calibrated '%s', force sensor calibrated "
                      "'%s': fix: calibrate it with the vendor's tools (handle free); swell's start-up inits it and "
                      "gives no force until both are true" % (pc, fc))
            else:
                r.add("ok", "calibration", "position and force sensor calibrated (asked the device)")
        except OSError as e:
            hm_err = str(e)
    elif have_status and heard:
        pushed = 1 if st & DEV_ESTOP else 0
    if pushed < 0 and state == 4 and hb["err"] == 11:
        pushed = 1
    if pushed > 0:
        r.add("FAIL", "e-stop", "%s: fix: release the device's e-stop (then swell-tool clear if the controller "
              "faulted)" % ("the device says its emergency button is pushed" if o.hm
                            else "the device reports an e-stop (or that it is not rendering)"))
    elif pushed == 0:
        r.add("ok", "e-stop", "released%s" % (" (asked the device)" if o.hm else ""))
    elif o.hm:
        r.add("FAIL", "e-stop", "cannot ask the device: %s: fix: check --hm HOST[:PORT]" % hm_err)
    else:
        r.add("skip", "e-stop", "no device status heard; --hm HOST asks a HapticMaster itself")

    if o.hm:
        _effects(r, o, state)
    else:
        r.add("skip", "effects", "needs --hm HOST[:PORT] (the HapticMaster's own interface, read only)")
    return r


def _g3(v: float) -> str:
    return "%.3g" % v


def _g(v: float) -> str:
    return "%g" % v


def check(spec: str = "udp:127.0.0.1:%d" % T.UDP_PORT_CLIENTS, timeout: float = 1.0, hm: Optional[str] = None,
          max_force_N: float = FORCE_N, max_rate_N_s: float = RATE_N_S, max_rtt_ms: float = RTT_MS) -> CheckResult:
    """swell-tool check on the link spec: a link that cannot be opened, or on which no controller is
    heard within timeout seconds, is the first line's FAIL and every other check is skipped."""
    try:
        c = connect(spec, timeout)
    except (NoController, LinkError) as e:
        r = CheckResult()
        r.add("FAIL", "link", "%s: fix: start swell-ctl (or power the board); CAN: ip link set can0 up type can "
              "bitrate 1000000, 120 ohm at each end; USB: the cable" % e)
        for name in ("controller", "device", "round trip", "frame", "force", "e-stop", "effects"):
            r.add("skip", name, "no controller to ask")
        return r
    with c:
        return c.check(hm, max_force_N, max_rate_N_s, max_rtt_ms)
