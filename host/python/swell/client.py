"""A conversation with a running swell controller over its host link: its identity and state,
parameters by name in their units, commands, the chain's check, and telemetry into numpy.
Synchronous: every call that waits has a timeout and raises on it. Received frames are decoded in
bulk (bulk.py): the controller sends telemetry at its tick rate, 2500 Hz."""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from decimal import Decimal, InvalidOperation, ROUND_HALF_EVEN
from typing import Callable, Dict, Iterator, List, MutableMapping, Optional, Tuple, Union

import numpy as np

from . import _tables as T
from . import bulk
from . import proto
from .bulk import Frames
from .link import Link, RecordingWriter, encode, open_link

SILENT_S = 0.6  # six heartbeats (10 Hz) missed: the controller is gone, as swell-tool judges it
RESEND_S = 0.25  # a request unanswered this long is sent again (a lost frame), as swell-tool does


class SwellError(Exception):
    """Base of swell's errors; str() is the one-line reason the C tools print."""


class NoController(SwellError):
    """Nothing answered on the link within the timeout."""


class Timeout(SwellError):
    """The controller was there and did not answer in time."""


class Refused(SwellError):
    """The controller refused a request (PARAM_NACK): .error is its swell_err code, .reason its text
    (the C tools' words for it). A refused request changed nothing."""

    def __init__(self, what: str, error: int, detail: str = ""):
        self.error = error
        self.reason = proto.error_text(error)
        super().__init__("%s refused by the controller: %s%s" % (what, self.reason, detail))


class UnknownParameter(SwellError, KeyError):
    """A parameter name the table does not have."""

    def __str__(self) -> str:  # KeyError would quote the message
        return self.args[0]


class BadValue(SwellError, ValueError):
    """A value that is not a number in the parameter's unit (or one with another SI prefix)."""


@dataclass(frozen=True)
class Param:
    """One controller parameter as its table defines it (raw integers, physical = raw * factor)."""
    id: int
    name: str
    min: int
    max: int
    default: int
    factor: Decimal
    unit: str
    read_only: bool
    when: str
    desc: str

    def to_raw(self, value: Union[float, str]) -> int:
        """The raw value of a number in this parameter's unit, or of a string with a unit ("80 g",
        "0.08kg", "4 cm"), rounded half to even; BadValue for anything else."""
        if isinstance(value, str):
            text = value.strip()
            k = len(text)
            while k and not (text[k - 1].isdigit() or text[k - 1] == "."):
                k -= 1
            try:
                num = Decimal(text[:k])
            except InvalidOperation:
                raise BadValue("%s: '%s' is not a number" % (self.name, value)) from None
            unit = text[k:].strip()
            try:
                num = _convert(num, unit, self.unit, self.name)
            except ValueError:
                raise BadValue("%s: unit '%s' is not %s (or %s with another prefix)"
                               % (self.name, unit, self.unit or "(none)", self.unit or "(none)")) from None
        else:
            try:
                num = Decimal(str(float(value)))
            except (TypeError, ValueError, InvalidOperation):
                raise BadValue("%s: %r is not a number" % (self.name, value)) from None
        if not num.is_finite():
            raise BadValue("%s: '%s' is not a number" % (self.name, value))
        return int((num / self.factor).to_integral_value(ROUND_HALF_EVEN))

    def to_value(self, raw: int) -> float:
        return float(raw * self.factor)


PARAMS: Dict[str, Param] = {
    p[1]: Param(p[0], p[1], p[2], p[3], p[4], Decimal(p[5]), p[6], p[7], p[8], p[9]) for p in T.PARAMS
}


_PREFIX = {"k": Decimal(1000), "": Decimal(1), "c": Decimal("0.01"), "m": Decimal("0.001"), "u": Decimal("0.000001")}
_SCENE_UNITS = {"pool.nx": "cells", "pool.ny": "cells", "pool.dx": "mm", "pool.depth": "mm", "solver.hz": "Hz"}


def _convert(value: Decimal, unit: str, want: str, where: str) -> Decimal:
    """value in unit as a number in the unit `want`, through SI prefixes (80 g, 0.08 kg, 4 cm)."""
    if unit == want or not unit:
        return value
    for pf, scale in _PREFIX.items():
        if pf and unit.startswith(pf) and len(unit) > len(pf):
            base = unit[len(pf):]
        elif not pf:
            base = unit
        else:
            continue
        for wpf, wscale in _PREFIX.items():
            if want == wpf + base:
                return value * scale / wscale
    raise ValueError("%s: unit '%s' is not one for %s" % (where, unit, want or "a plain number"))


def parse_scene(path: str) -> List[Tuple[int, str, float]]:
    """(line, name, value in the parameter's unit) of a scene file; ValueError names a bad line."""
    out = []
    with open(path) as f:
        for n, text in enumerate(f, 1):
            text = text.split("#", 1)[0].strip()
            if not text:
                continue
            if "=" not in text:
                raise ValueError("%s:%d: not 'name = value unit'" % (path, n))
            name, rest = (x.strip() for x in text.split("=", 1))
            words = rest.split()
            if not words or len(words) > 2:
                raise ValueError("%s:%d: '%s' is not 'value unit'" % (path, n, rest))
            if name in _SCENE_UNITS:
                want = _SCENE_UNITS[name]
            elif name in PARAMS:
                want = PARAMS[name].unit
            else:
                raise ValueError("%s:%d: unknown key '%s'" % (path, n, name))
            try:
                value = Decimal(words[0])
            except ArithmeticError:
                raise ValueError("%s:%d: '%s' is not a number" % (path, n, words[0])) from None
            unit = words[1] if len(words) == 2 else ""
            if want == "cells" and unit == "cells":
                unit = want
            out.append((n, name, float(_convert(value, unit, want, "%s:%d" % (path, n)))))
    return out


@dataclass
class Info:
    """The controller's identity (CTL_INFO) and pool (SCENE)."""
    node: int
    firmware: str
    object_mm: tuple
    grid: tuple
    dx_mm: float
    depth_mm: float


@dataclass
class Energy:
    """The controller's energy account of its run (ENERGY, 10 Hz; docs/energy.md)."""
    created_mJ: float
    balance_mJ: float
    passivity: bool
    acting: bool


class Params(MutableMapping):
    """c.params["body.damper"] reads from the controller; assignment writes and waits for the
    answer. Values are numbers in the parameter's unit (PARAMS[name].unit) or strings with a unit
    ("80 g"). A refused value raises Refused with the controller's reason and changes nothing."""

    def __init__(self, ctl: "Controller"):
        self._c = ctl

    def _desc(self, name: str) -> Param:
        p = PARAMS.get(name)
        if p is None:
            raise UnknownParameter("no parameter '%s'; there are: %s" % (name, " ".join(PARAMS)))
        return p

    def __getitem__(self, name: str) -> float:
        p = self._desc(name)
        return p.to_value(self._c.request(False, p.id, 0, "get %s" % name))

    def raw(self, name: str) -> int:
        """The raw integer value, as the wire carries it."""
        return self._c.request(False, self._desc(name).id, 0, "get %s" % name)

    def __setitem__(self, name: str, value: Union[float, str]) -> None:
        p = self._desc(name)
        if p.read_only:
            raise BadValue("%s is read only: the controller measures it (get it)" % name)
        self.set_raw(name, p.to_raw(value))

    def set_raw(self, name: str, raw: int) -> None:
        """Sets the raw integer value, as the wire carries it."""
        p = self._desc(name)
        if not -(1 << 31) <= raw < (1 << 31):
            raise Refused("set %s" % name, 2, " (raw %d is beyond the wire's 32 bits)" % raw)
        try:
            self._c.request(True, p.id, int(raw), "set %s" % name)
        except Refused as e:
            try:
                was = "; %s stays %.7g%s" % (name, p.to_value(self._c.request(False, p.id, 0, "get %s" % name)),
                                             " " + p.unit if p.unit else "")
            except SwellError:
                was = ""
            raise Refused("set %s" % name, e.error, " (state %s)%s" % (self._c.state_now(), was)) from None

    def __delitem__(self, name: str) -> None:
        raise TypeError("parameters cannot be deleted")

    def __iter__(self) -> Iterator[str]:
        return iter(PARAMS)

    def __len__(self) -> int:
        return len(PARAMS)


SAMPLE_DTYPE = np.dtype([("t", "f8"), ("seq", "u1"), ("x", "f4"), ("y", "f4"), ("z", "f4"), ("submersion", "f4"),
                         ("fx", "f4"), ("fy", "f4"), ("fz", "f4"), ("limits", "u1")])
STATE_DTYPE = np.dtype([("t", "f8"), ("state", "u1"), ("err", "u1"), ("bad_frames", "u2"), ("overruns", "u2")])
ENERGY_DTYPE = np.dtype([("t", "f8"), ("created_mJ", "f8"), ("balance_mJ", "f8"), ("passivity", "u1"),
                         ("acting", "u1")])


def _factor(msg: str, fieldname: str) -> float:
    return float(next(f.factor for f in proto.MESSAGES[msg].fields if f.name == fieldname))


class Controller:
    """A controller on a link. Use swell.connect()."""

    def __init__(self, link: Link, timeout: float = 2.0):
        self.link = link
        self.name = link.name
        self.timeout = timeout
        self.node: Optional[int] = None
        self.heartbeat: Optional[proto.Message] = None
        self.latest: Dict[str, proto.Message] = {}
        self._hb_time = 0.0
        self._seq = 0
        self._pkt_seq = 0
        self._keep_due = 0.0
        self._answers: List[proto.Message] = []
        self._sink: Optional[Callable[[Frames, bulk.Decoded], None]] = None
        self._rx = Frames.empty(4096)
        self.params = Params(self)
        self._wait_heartbeat(timeout)

    # ---- the link ----
    def _keepalive(self, now: float) -> None:
        """UDP: a HEARTBEAT to the controller once a second, so that it keeps this client (every
        100 ms to every node until one is heard)."""
        if not self.link.keepalive or now < self._keep_due:
            return
        nodes = range(T.NODE_MAX + 1) if self.node is None else [self.node]
        for k in nodes:
            hb = proto.Message("HEARTBEAT", k, {"version": T.PROTO_VERSION})
            self.link.send(("pkt", 0, proto.packet_encode(k, 0, [hb])))
        self._keep_due = now + (0.1 if self.node is None else T.UDP_KEEPALIVE_MS / 1000.0)

    def _take(self, fr: Frames, dec: bulk.Decoded) -> None:
        """Takes in what our node said in these frames: heartbeat, scene, info, pose, answers."""
        if self.node is None:
            hb = dec.msgs.get("HEARTBEAT")
            if hb is not None and len(hb["node"]):
                self.node = int(hb["node"][0])
        if self.node is None:
            return
        for name, d in dec.msgs.items():
            if name in ("PARAM_SET", "PARAM_GET", "ENTER_BOOTLOADER", "FORCE_CMD") or name.startswith("DEVICE_"):
                continue  # another host's requests, or device traffic on a shared bus
            sel = np.flatnonzero(d["node"] == self.node)
            if not len(sel):
                continue
            if name in ("PARAM_ACK", "PARAM_NACK"):
                for i in sel:
                    self._answers.append(self._msg(name, d, i))
                continue
            if name == "HEIGHT_QUAD":
                continue
            i = sel[-1]
            self.latest[name] = self._msg(name, d, i)
            if name == "HEARTBEAT":
                self.heartbeat = self.latest[name]
                self._hb_time = float(d["t"][i])
        if self._sink:
            self._sink(fr, dec)

    def _msg(self, name: str, d: Dict[str, np.ndarray], i: int) -> proto.Message:
        return proto.Message(name, int(d["node"][i]), {f.name: int(d[f.name][i]) for f in proto.MESSAGES[name].fields})

    def _pump(self, timeout_s: float) -> int:
        """Frames for up to timeout_s (returns soon after the first ones: everything waiting is taken
        in bulk); 0: only what is waiting. Returns the number of frames."""
        if timeout_s <= 0:
            n = self.link.fill(self._rx, 0, 0.0, 0.0, self._keepalive)
        else:
            now = time.monotonic()
            n = self.link.fill(self._rx.head(1), 0, now + timeout_s, timeout_s, self._keepalive)
            if n:  # more may wait behind the first: take them too (up to the buffer), without waiting
                n = self.link.fill(self._rx, n, 0.0, 0.0)
        if n == 0:
            return 0
        fr = self._rx.head(n)
        fr = Frames(fr.data.copy(), fr.length.copy(), fr.t.copy(), fr.can_id.copy())
        self._take(fr, bulk.decode(fr, self.link.carrier))
        return n

    def _wait_heartbeat(self, timeout: float) -> None:
        end = time.monotonic() + timeout
        while self.node is None:
            left = end - time.monotonic()
            if left <= 0:
                raise NoController("no controller heard on %s within %d ms (is swell-ctl running with its host "
                                   "link there%s?)" % (self.name, round(timeout * 1000),
                                                       ", and one of its 4 client slots free"
                                                       if self.link.keepalive else ""))
            self._pump(min(left, 0.05))

    def _send(self, name: str, raw: Dict[str, int]) -> None:
        m = proto.Message(name, self.node or 0, raw)
        self._pkt_seq = (self._pkt_seq + 1) & 0xFF
        self.link.send(encode(self.link.carrier, m.node, self._pkt_seq, m))

    def request(self, set_: bool, pid: int, value: int, what: str) -> int:
        """A PARAM_SET (set_) or PARAM_GET of parameter id pid; returns the value in force from the
        PARAM_ACK. Sent again every 250 ms until the timeout; Refused on a PARAM_NACK (error code
        and reason), Timeout without an answer."""
        self._seq = (self._seq + 1) & 0xFF
        seq = self._seq
        raw = {"id": pid, "value": value, "seq": seq} if set_ else {"id": pid, "seq": seq}
        self._answers.clear()
        end = time.monotonic() + self.timeout
        while time.monotonic() < end:
            self._send("PARAM_SET" if set_ else "PARAM_GET", raw)
            again = min(end, time.monotonic() + RESEND_S)
            while time.monotonic() < again:
                self._pump(again - time.monotonic())
                for m in self._answers:
                    if m["seq"] == seq and m["id"] == pid:
                        self._answers.clear()
                        if m.name == "PARAM_NACK":
                            raise Refused(what, m["err"])
                        return m["value"]
                self._answers.clear()
        if time.monotonic() - self._hb_time > max(self.timeout, SILENT_S):
            raise Timeout("%s: the controller (node %d on %s) went silent: no heartbeat for %.1f s and no answer"
                          % (what, self.node, self.name, time.monotonic() - self._hb_time))
        raise Timeout("%s: no answer from node %d on %s within %d ms (its heartbeat goes on)"
                      % (what, self.node, self.name, round(self.timeout * 1000)))

    # ---- what the controller says of itself ----
    @property
    def state(self) -> str:
        """The controller state from its latest heartbeat (boot, idle, armed, running, fault)."""
        self._fresh()
        return proto.state_name(self.heartbeat["state"])

    def state_now(self) -> str:
        """The state of the last heartbeat heard, without waiting for a fresh one."""
        return proto.state_name(self.heartbeat["state"]) if self.heartbeat else "?"

    @property
    def error(self) -> str:
        """The controller's last error, by name ("ok", "link silent", ...)."""
        self._fresh()
        return proto.error_text(self.heartbeat["err"])

    def _fresh(self) -> None:
        end = time.monotonic() + max(self.timeout, SILENT_S)
        self._pump(0)
        while time.monotonic() - self._hb_time > 0.15:
            if time.monotonic() > end:
                raise Timeout("the controller went silent (no heartbeat for %.1f s)"
                              % (time.monotonic() - self._hb_time))
            self._pump(0.05)

    def wait_full(self, timeout: float) -> bool:
        """Until a heartbeat, SCENE and CTL_INFO have all been heard (they come at 10 and 1 Hz)."""
        end = time.monotonic() + timeout
        while not all(k in self.latest for k in ("HEARTBEAT", "SCENE", "CTL_INFO")):
            if time.monotonic() >= end:
                return False
            self._pump(0.05)
        return True

    @property
    def info(self) -> Info:
        """Firmware version, object size and pool geometry (CTL_INFO and SCENE, 1 Hz)."""
        wait = max(self.timeout, 1.5)
        if not self.wait_full(wait):
            raise Timeout("no CTL_INFO and SCENE from the controller in %.1f s" % wait)
        i, s = self.latest["CTL_INFO"], self.latest["SCENE"]
        return Info(self.node, "%d.%d.%d" % (i["fw_major"], i["fw_minor"], i["fw_patch"]),
                    tuple(i.physical(k) for k in ("obj_a_100um", "obj_b_100um", "obj_h_100um")),
                    (s["nx"], s["ny"]), s.physical("dx_um"), s.physical("depth_10um"))

    @property
    def energy(self) -> Energy:
        """Energy created and the balance D of the controller's run, whether its passivity
        controller is on and acted since the last report (ENERGY, 10 Hz)."""
        end = time.monotonic() + max(self.timeout, 0.5)
        while "ENERGY" not in self.latest:
            if time.monotonic() > end:
                raise Timeout("no ENERGY from the controller in %.1f s" % max(self.timeout, 0.5))
            self._pump(0.1)
        e = self.latest["ENERGY"]
        return Energy(e.physical("created_uJ"), e.physical("balance_10uJ"), bool(e["passivity"]), bool(e["acting"]))

    # ---- commands ----
    def _command(self, name: str) -> None:
        try:
            self.request(True, T.PARAM_COMMAND_ID, T.COMMANDS[name], name)
        except Refused as e:
            raise Refused(name, e.error, " (state %s)" % self.state_now()) from None

    def start(self) -> None:
        """RUN: armed -> running (the device powered, its e-stop released)."""
        self._command("run")

    def stop(self) -> None:
        """STOP: the force law off, running -> armed."""
        self._command("stop")

    def reset(self) -> None:
        """CLEAR: fault -> idle once the device is heard again."""
        self._command("clear")

    def estop(self) -> None:
        """Software stop: autorun off and STOP at once (the force law off until RUN). Not the
        device's own e-stop."""
        self.request(True, PARAMS["ctl.autorun"].id, 0, "estop: set ctl.autorun")
        self._command("stop")

    def load_scene(self, path: str) -> List[str]:
        """Sends a scene file (`name = value unit` lines) as one change, parameters in file order; if
        the controller refuses one, those already set are put back in reverse order and Refused names
        the line. The pool (pool.*) must be the running one: changing it is swell-tool's (scene load).
        Returns the names set."""
        entries = parse_scene(path)
        self.info  # waits for SCENE
        scene = self.latest["SCENE"]
        running = {"pool.nx": scene["nx"], "pool.ny": scene["ny"], "pool.dx": scene.physical("dx_um"),
                   "pool.depth": scene.physical("depth_10um")}
        for line, name, value in entries:
            if name in running and abs(value - running[name]) > 1e-9:
                raise BadValue("%s:%d: %s = %g, the running pool has %g: change the pool with swell-tool scene load"
                               % (path, line, name, value, running[name]))
        done: List[Tuple[str, int]] = []
        for line, name, value in entries:
            if name in running or name == "solver.hz":
                continue
            before = self.params.raw(name)
            try:
                self.request(True, PARAMS[name].id, PARAMS[name].to_raw(value), "set %s" % name)
            except Refused as e:
                for put, raw in reversed(done):
                    self.params.set_raw(put, raw)
                raise Refused("%s:%d: set %s" % (path, line, name), e.error, " (state %s); the %d set before it put "
                              "back" % (self.state_now(), len(done))) from None
            done.append((name, before))
        return [n for n, _ in done]

    def wait_state(self, state: str, timeout: float = 5.0) -> None:
        """Until the heartbeat says `state`; Timeout after `timeout` seconds."""
        end = time.monotonic() + timeout
        while self.state != state:
            if time.monotonic() > end:
                raise Timeout("state %s, not %s after %.1f s" % (self.state, state, timeout))
            self._pump(0.05)

    # ---- the chain's check ----
    def check(self, hm: Optional[str] = None, max_force_N: float = 2.0, max_rate_N_s: float = 20.0,
              max_rtt_ms: float = 20.0):
        """swell-tool check on this controller: the same checks, thresholds, verdicts and fix texts
        (swell.check.CheckResult; .ok is True when none failed). hm: HOST[:PORT] of a HapticMaster's
        own TCP interface, asked (read only) for its e-stop, calibration and swell's effects left on it."""
        from . import checks
        return checks.run(self, checks.Options(self.name, hm, max_force_N, max_rate_N_s, max_rtt_ms,
                                               round(self.timeout * 1000)))

    # ---- telemetry ----
    def capture(self, seconds: float) -> Frames:
        """Every frame of the link for `seconds`, as received (no decoding while it runs: the link's
        fill loop and a large socket buffer keep up with the tick rate). Timeout if the controller goes
        silent."""
        silent = max(self.timeout, SILENT_S)
        est = int(max(seconds, 0.0) * 8000) + 1024  # the tick rate's packets and some
        parts, fr, i = [], Frames.empty(est), 0
        end = time.monotonic() + seconds
        while True:
            i = self.link.fill(fr, i, end, silent, self._keepalive)
            now = time.monotonic()
            if i == len(fr):
                parts.append(fr)
                fr, i = Frames.empty(est // 2 + 1024), 0
                continue
            if now < end:
                raise Timeout("the controller went silent (nothing on %s for %.1f s)" % (self.name, silent))
            break
        parts.append(fr.head(i))
        return Frames.concat(parts)

    def stream(self) -> "Stream":
        """with c.stream() as s: for sample in s: ...; or s.to_numpy(seconds=5)."""
        return Stream(self)

    def record(self, path: str, seconds: float) -> int:
        """Records every frame the link receives for `seconds` into a SWELLREC file (the C links'
        recording format; swell-view --source replay:FILE plays it), written a tenth of a second at a
        time. Returns the number of frames."""
        n = 0
        with RecordingWriter(path, self.link.carrier) as w:
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                fr = self.capture(min(0.1, max(end - time.monotonic(), 0.0)))
                w.write_frames(fr)
                n += len(fr)
                self._take(fr, bulk.decode(fr, self.link.carrier))
        return n

    def close(self) -> None:
        self.link.close()

    def __enter__(self) -> "Controller":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


@dataclass
class Sample:
    """One object sample: the pose and force of one sequence number."""
    t: float
    seq: int
    pose_mm: tuple
    submersion_pct: float
    force_N: tuple
    limits: int = 0  # bit 0: |F| clamped to force.max, bit 1: dF/dt limited by force.rate


@dataclass
class Telemetry:
    """What s.to_numpy() took: structured arrays, times in seconds since the capture began.

    samples: t, seq, x, y, z (mm, the object's bottom centre in the pool), submersion (%), fx, fy, fz
    (N, on the device), limits (OBJECT_POSE joined with the OBJECT_FORCE of its seq, 100 a second);
    heights: (n, ny, nx) float32 snapshots of the water's height (mm above the rest level, NaN where
    no height has come yet) at heights_t; states: t, state, err, bad_frames, overruns of every
    heartbeat; energy: t, created_mJ, balance_mJ, passivity, acting of every ENERGY (the controller's
    energy account, 10 a second, docs/energy.md). packets / lost_packets: the frames received and
    the ones missing by the packet sequence numbers the controller sent; refused: frames the decoder
    refused."""
    samples: np.ndarray
    heights: np.ndarray
    heights_t: np.ndarray
    states: np.ndarray
    packets: int = 0
    lost_packets: int = 0
    lost_samples: int = 0
    refused: int = 0
    seconds: float = 0.0
    t0: float = 0.0  # the capture's start, monotonic seconds
    energy: np.ndarray = field(default_factory=lambda: np.zeros(0, ENERGY_DTYPE))

    def __getitem__(self, key):
        return self.samples[key]

    def __len__(self) -> int:
        return len(self.samples)

    @property
    def loss(self) -> float:
        """The fraction of the controller's packets that did not arrive."""
        sent = self.packets + self.lost_packets
        return self.lost_packets / sent if sent else 0.0


def join_samples(pose: Dict[str, np.ndarray], force: Dict[str, np.ndarray], t0: float) -> np.ndarray:
    """OBJECT_POSE rows joined with the first OBJECT_FORCE after each of the same seq."""
    if not len(pose.get("seq", ())) or not len(force.get("seq", ())):
        return np.zeros(0, SAMPLE_DTYPE)
    j = np.searchsorted(force["order"], pose["order"])
    ok = j < len(force["seq"])
    ok[ok] &= force["seq"][j[ok]] == pose["seq"][ok]
    i, j = np.flatnonzero(ok), j[ok]
    out = np.zeros(len(i), SAMPLE_DTYPE)
    out["t"] = pose["t"][i] - t0
    out["seq"] = pose["seq"][i]
    for k, w in (("x", "x_10um"), ("y", "y_10um"), ("z", "z_10um")):
        out[k] = pose[w][i] * _factor("OBJECT_POSE", w)
    out["submersion"] = pose["submersion_halfpct"][i] * _factor("OBJECT_POSE", "submersion_halfpct")
    for k, w in (("fx", "fx_cN"), ("fy", "fy_cN"), ("fz", "fz_cN")):
        out[k] = force[w][j] * _factor("OBJECT_FORCE", w)
    out["limits"] = force["limits"][j]
    return out


class Stream:
    """Telemetry: samples (OBJECT_POSE joined with the OBJECT_FORCE of the same seq) and heights.
    Iterating yields Sample objects as they come; to_numpy(seconds) takes a span into arrays."""

    def __init__(self, ctl: Controller):
        self.c = ctl
        self.grid: Optional[np.ndarray] = None  # the latest heights, mm, rows y, columns x (NaN: none yet)
        self.lost = 0  # samples missing by their seq since the stream began
        self.lost_packets = 0
        self.packets = 0
        self._last_seq: Optional[int] = None
        self._ready: List[Sample] = []
        self.t0 = time.monotonic()  # Sample.t counts from here: the stream's start
        self._pose_left: Optional[Dict[str, np.ndarray]] = None
        self._hq = _factor("HEIGHT_QUAD", "h0")

    def __enter__(self) -> "Stream":
        self.c._sink = self._chunk
        return self

    def __exit__(self, *exc) -> None:
        self.c._sink = None

    def _grid_for(self) -> None:
        s = self.c.latest.get("SCENE")
        if s is not None and (self.grid is None or self.grid.shape != (s["ny"], s["nx"])):
            self.grid = np.full((s["ny"], s["nx"]), np.nan, np.float32)

    def _heights(self, q: Dict[str, np.ndarray], upto: Optional[float] = None, start: int = 0) -> int:
        """Applies the HEIGHT_QUADs from index start whose time is at most upto to the grid, the last
        of each cell winning; returns the index after the last one applied."""
        self._grid_for()
        if self.grid is None or not len(q.get("row", ())):
            return start
        stop = len(q["row"]) if upto is None else int(np.searchsorted(q["t"], upto, side="right"))
        if stop <= start:
            return start
        sl = slice(start, stop)
        ny, nx = self.grid.shape
        y = (q["tile_y"][sl] * T.TILE + q["row"][sl])[:, None]
        x = (q["tile_x"][sl] * T.TILE + 4 * q["half"][sl])[:, None] + np.arange(4)[None, :]
        h = np.stack([q["h%d" % k][sl] for k in range(4)], axis=1) * self._hq
        y = np.broadcast_to(y, x.shape)
        inside = (y < ny) & (x < nx)
        cell = (y * nx + x)[inside][::-1]  # newest first: np.unique keeps the first of each cell
        val = h[inside][::-1]
        cell, first = np.unique(cell, return_index=True)
        self.grid.reshape(-1)[cell] = val[first]
        return stop

    def _count(self, dec: bulk.Decoded, fr: Frames) -> None:
        own = ~dec.refused & (dec.node == self.c.node)
        self.packets += int(own.sum())
        if self.c.link.carrier == "pkt":
            seq = dec.seq[own]
            if self._pkt_last is not None and len(seq):
                seq = np.concatenate([[self._pkt_last], seq])
                self.lost_packets += bulk.lost_by_seq(seq)
            elif len(seq):
                self.lost_packets += bulk.lost_by_seq(seq)
            if len(seq):
                self._pkt_last = int(seq[-1])

    _pkt_last: Optional[int] = None

    def _chunk(self, fr: Frames, dec: bulk.Decoded) -> None:
        node = self.c.node
        self._count(dec, fr)
        q = dec.msgs.get("HEIGHT_QUAD")
        if q is not None:
            self._heights(bulk.of_node(q, node))
        pose = dec.msgs.get("OBJECT_POSE")
        force = dec.msgs.get("OBJECT_FORCE")
        pose = bulk.of_node(pose, node) if pose is not None else None
        if self._pose_left is not None:  # a pose whose force was in the frames after it
            pose = self._pose_left if pose is None else {k: np.concatenate([self._pose_left[k], pose[k]])
                                                          for k in pose}
            self._pose_left = None
        if pose is None or not len(pose["seq"]):
            return
        force = bulk.of_node(force, node) if force is not None else {"seq": np.zeros(0, np.int64)}
        rows = join_samples(pose, force, self.t0) if len(force["seq"]) else np.zeros(0, SAMPLE_DTYPE)
        if not len(rows) or rows["seq"][-1] != pose["seq"][-1]:
            self._pose_left = {k: v[-1:] for k, v in pose.items()}
        for r in rows:
            seq = int(r["seq"])
            if self._last_seq is not None:
                self.lost += (seq - self._last_seq - 1) & 0xFF
            self._last_seq = seq
            self._ready.append(Sample(float(r["t"]), seq, (float(r["x"]), float(r["y"]), float(r["z"])),
                                      float(r["submersion"]), (float(r["fx"]), float(r["fy"]), float(r["fz"])),
                                      int(r["limits"])))

    def __iter__(self) -> Iterator[Sample]:
        while True:
            while not self._ready:
                self.c._pump(0.05)
                if time.monotonic() - self.c._hb_time > max(self.c.timeout, SILENT_S):
                    raise Timeout("the controller went silent (no heartbeat for %.1f s)"
                                  % (time.monotonic() - self.c._hb_time))
            yield self._ready.pop(0)

    def to_numpy(self, seconds: float, heights_hz: float = 10.0) -> Telemetry:
        """`seconds` of telemetry as arrays (Telemetry: .samples, .heights, .states; t["z"] is
        t.samples["z"]). The frames are received as they come and decoded in bulk at the end, so
        that the tick rate's packets are not lost to Python's per-message cost. Heights are taken
        as snapshots heights_hz times a second (0: none); s.grid is the last."""
        self.c._sink = None
        try:
            fr = self.c.capture(seconds)
            t0 = float(fr.t[0]) if len(fr) else time.monotonic()
            dec = bulk.decode(fr, self.c.link.carrier)
            self.c._take(fr, dec)
        finally:
            self.c._sink = self._chunk
        node = self.c.node
        own = ~dec.refused & (dec.node == node)
        pose = bulk.of_node(dec.msgs["OBJECT_POSE"], node) if "OBJECT_POSE" in dec.msgs else {}
        force = bulk.of_node(dec.msgs["OBJECT_FORCE"], node) if "OBJECT_FORCE" in dec.msgs else {}
        samples = join_samples(pose, force, t0)
        lost_samples = bulk.lost_by_seq(samples["seq"]) if len(samples) else 0
        lost_packets = 0
        if self.c.link.carrier == "pkt" and own.any():
            # the poses (100 a second) are the clock that tells a gap of a whole wrap of the packet seq
            rows = np.flatnonzero(own)
            clock = np.zeros(len(rows))
            if len(pose.get("seq", ())):
                pc = bulk.unwrap(pose["seq"])
                k = np.searchsorted(pose["order"] // 64, rows, side="right") - 1
                clock = np.where(k >= 0, pc[np.maximum(k, 0)], 0)
            lost_packets = bulk.lost_by_seq(dec.seq[rows], clock)
        hb = bulk.of_node(dec.msgs["HEARTBEAT"], node) if "HEARTBEAT" in dec.msgs else {}
        states = np.zeros(len(hb.get("seq", ())), STATE_DTYPE)
        for k in ("state", "err", "bad_frames", "overruns"):
            if len(states):
                states[k] = hb[k]
        if len(states):
            states["t"] = hb["t"] - t0
        en = bulk.of_node(dec.msgs["ENERGY"], node) if "ENERGY" in dec.msgs else {}
        energy = np.zeros(len(en.get("t", ())), ENERGY_DTYPE)
        if len(energy):
            energy["t"] = en["t"] - t0
            energy["created_mJ"] = en["created_uJ"] * 0.001
            energy["balance_mJ"] = en["balance_10uJ"] * 0.01
            energy["passivity"] = en["passivity"]
            energy["acting"] = en["acting"]
        q = bulk.of_node(dec.msgs["HEIGHT_QUAD"], node) if "HEIGHT_QUAD" in dec.msgs else {}
        snaps, snap_t, at = [], [], 0
        if heights_hz > 0 and seconds > 0:
            for k in range(1, int(seconds * heights_hz) + 1):
                at = self._heights(q, t0 + k / heights_hz, at)
                if self.grid is not None:
                    snaps.append(self.grid.copy())
                    snap_t.append(k / heights_hz)
        self._heights(q, None, at)
        self.packets += int(own.sum())
        self.lost_packets += lost_packets
        self.lost += lost_samples
        shape = self.grid.shape if self.grid is not None else (0, 0)
        heights = np.array(snaps, np.float32) if snaps else np.zeros((0,) + shape, np.float32)
        return Telemetry(samples, heights, np.array(snap_t),
                         states, int(own.sum()), lost_packets, lost_samples, int(dec.refused.sum()),
                         float(seconds), t0, energy)


def connect(spec: str = "udp:127.0.0.1:%d" % T.UDP_PORT_CLIENTS, timeout: float = 2.0) -> Controller:
    """A controller on the link spec (swell-tool's --link spellings); NoController if none is heard
    within timeout seconds, LinkError if the link cannot be opened."""
    link = open_link(spec, timeout)
    try:
        return Controller(link, timeout)
    except BaseException:
        link.close()
        raise
