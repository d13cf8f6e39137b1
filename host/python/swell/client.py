"""A conversation with a running swell controller over its host link: its identity and state,
parameters by name in their units, commands, and telemetry into numpy. Synchronous: every call
that waits has a timeout and raises on it."""
from __future__ import annotations

import time
from dataclasses import dataclass
from decimal import Decimal, ROUND_HALF_EVEN
from typing import Dict, Iterator, List, MutableMapping, Optional, Tuple

from . import _tables as T
from . import proto
from .link import Frame, Link, RecordingWriter, decode, encode, open_link

SILENT_S = 0.6  # six heartbeats (10 Hz) missed: the controller is gone, as swell-tool judges it


class SwellError(Exception):
    """Base of swell's errors; str() is the one-line reason the C tools print."""


class NoController(SwellError):
    """Nothing answered on the link within the timeout."""


class Timeout(SwellError):
    """The controller was there and did not answer in time."""


class Refused(SwellError):
    """The controller refused a request (PARAM_NACK): .error is its swell_err code, .reason its text.
    A refused request changed nothing."""

    def __init__(self, what: str, error: int):
        self.error = error
        self.reason = proto.error_text(error)
        super().__init__("%s: refused by the controller: %s" % (what, self.reason))


class UnknownParameter(SwellError, KeyError):
    def __str__(self) -> str:  # KeyError would quote the message
        return self.args[0]


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

    def to_raw(self, value: float) -> int:
        return int((Decimal(str(value)) / self.factor).to_integral_value(ROUND_HALF_EVEN))

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
    answer. Values are in the parameter's unit (PARAMS[name].unit)."""

    def __init__(self, ctl: "Controller"):
        self._c = ctl

    def _desc(self, name: str) -> Param:
        p = PARAMS.get(name)
        if p is None:
            raise UnknownParameter("unknown parameter '%s' (swell.PARAMS lists them)" % name)
        return p

    def __getitem__(self, name: str) -> float:
        p = self._desc(name)
        return p.to_value(self._c.request("PARAM_GET", {"id": p.id}, name))

    def raw(self, name: str) -> int:
        """The raw integer value, as the wire carries it."""
        return self._c.request("PARAM_GET", {"id": self._desc(name).id}, name)

    def __setitem__(self, name: str, value: float) -> None:
        p = self._desc(name)
        if p.read_only:
            raise Refused("set %s" % name, 5)
        raw = p.to_raw(value)
        if not -(1 << 31) <= raw < (1 << 31):
            raise Refused("set %s = %s %s" % (name, value, p.unit), 2)
        self._c.request("PARAM_SET", {"id": p.id, "value": raw}, "set %s = %s %s" % (name, value, p.unit))

    def set_raw(self, name: str, raw: int) -> None:
        """Sets the raw integer value, as the wire carries it."""
        self._c.request("PARAM_SET", {"id": self._desc(name).id, "value": int(raw)}, "set %s = raw %d" % (name, raw))

    def __delitem__(self, name: str) -> None:
        raise TypeError("parameters cannot be deleted")

    def __iter__(self) -> Iterator[str]:
        return iter(PARAMS)

    def __len__(self) -> int:
        return len(PARAMS)


class Controller:
    """A controller on a link spec (udp:127.0.0.1:47802, can:can0). Use swell.connect()."""

    def __init__(self, link: Link, timeout: float = 2.0):
        self.link = link
        self.timeout = timeout
        self.node: Optional[int] = None
        self.heartbeat: Optional[proto.Message] = None
        self.latest: Dict[str, proto.Message] = {}
        self._seq = 0
        self._pkt_seq = 0
        self._keep_due = 0.0
        self._sink = None  # a callable given every (time, message) of our node
        self.params = Params(self)
        self._wait_heartbeat(timeout)

    # ---- the link ----
    def _keepalive(self) -> None:
        if self.link.carrier != "pkt" or time.monotonic() < self._keep_due:
            return
        nodes = range(T.NODE_MAX + 1) if self.node is None else [self.node]
        for k in nodes:
            hb = proto.Message("HEARTBEAT", k, {"version": T.PROTO_VERSION})
            self.link.send(("pkt", 0, proto.packet_encode(k, 0, [hb])))
        self._keep_due = time.monotonic() + (0.1 if self.node is None else T.UDP_KEEPALIVE_MS / 1000.0)

    def _pump(self, timeout_s: float) -> List[proto.Message]:
        """Frames for up to timeout_s (returns after the first one); the messages of our node."""
        self._keepalive()
        frame = self.link.recv(min(timeout_s, max(self._keep_due - time.monotonic(), 0.0)))
        if frame is None:
            return []
        try:
            msgs = decode(frame)
        except proto.ProtocolError:
            return []
        now = time.monotonic()
        out = []
        for m in msgs:
            if m.name == "HEARTBEAT" and self.node is None:
                self.node = m.node
            if m.node != self.node or m.name in ("PARAM_SET", "PARAM_GET"):
                continue
            self.latest[m.name] = m
            if m.name == "HEARTBEAT":
                self.heartbeat = m
                self._hb_time = now
            if self._sink:
                self._sink(now, frame, m)
            out.append(m)
        return out

    def _wait_heartbeat(self, timeout: float) -> None:
        end = time.monotonic() + timeout
        while self.node is None:
            left = end - time.monotonic()
            if left <= 0:
                raise NoController("no controller heard on the link in %.1f s" % timeout)
            self._pump(left)

    def _send(self, name: str, raw: Dict[str, int]) -> None:
        m = proto.Message(name, self.node or 0, raw)
        self._pkt_seq = (self._pkt_seq + 1) & 0xFF
        self.link.send(encode(self.link.carrier, m.node, self._pkt_seq, m))

    def request(self, name: str, raw: Dict[str, int], what: str) -> int:
        """Sends a PARAM_SET or PARAM_GET and returns the value of its PARAM_ACK; Refused on a
        PARAM_NACK, Timeout without an answer (retried once, as swell-tool does)."""
        self._seq = (self._seq + 1) & 0xFF
        body = dict(raw, seq=self._seq)
        for _attempt in range(2):
            self._send(name, body)
            end = time.monotonic() + self.timeout / 2
            while time.monotonic() < end:
                for m in self._pump(end - time.monotonic()):
                    if m.name in ("PARAM_ACK", "PARAM_NACK") and m["seq"] == self._seq and m["id"] == raw["id"]:
                        if m.name == "PARAM_NACK":
                            raise Refused(what, m["err"])
                        return m["value"]
        raise Timeout("%s: no answer from the controller in %.1f s" % (what, self.timeout))

    # ---- what the controller says of itself ----
    @property
    def state(self) -> str:
        """The controller state from its latest heartbeat (boot, idle, armed, running, fault)."""
        self._fresh()
        return proto.state_name(self.heartbeat["state"])

    @property
    def error(self) -> str:
        self._fresh()
        return proto.error_text(self.heartbeat["err"])

    def _fresh(self) -> None:
        end = time.monotonic() + SILENT_S
        while time.monotonic() - self._hb_time > 0.15:
            if time.monotonic() > end:
                raise Timeout("the controller went silent (no heartbeat for %.1f s)" % SILENT_S)
            self._pump(0.05)

    @property
    def info(self) -> Info:
        """Firmware version, object size and pool geometry (CTL_INFO and SCENE, 1 Hz)."""
        end = time.monotonic() + max(self.timeout, 1.5)
        while "CTL_INFO" not in self.latest or "SCENE" not in self.latest:
            if time.monotonic() > end:
                raise Timeout("no CTL_INFO and SCENE from the controller in %.1f s" % max(self.timeout, 1.5))
            self._pump(0.1)
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
        self.request("PARAM_SET", {"id": T.PARAM_COMMAND_ID, "value": T.COMMANDS[name]}, name)

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
        """Software stop: autorun off and STOP at once (the force law off until RUN)."""
        self.request("PARAM_SET", {"id": PARAMS["ctl.autorun"].id, "value": 0}, "estop: ctl.autorun = 0")
        self._command("stop")

    def load_scene(self, path: str) -> List[str]:
        """Sends a scene file (`name = value unit` lines) as one change, parameters in file order; if
        the controller refuses one, those already set are put back in reverse order and Refused names
        the line. The pool (pool.*) must be the running one: changing it is swell-tool's (scene load).
        Returns the names set."""
        entries = parse_scene(path)
        scene = self.latest.get("SCENE")
        if scene is None:
            self.info  # waits for SCENE
            scene = self.latest["SCENE"]
        running = {"pool.nx": scene["nx"], "pool.ny": scene["ny"], "pool.dx": scene.physical("dx_um"),
                   "pool.depth": scene.physical("depth_10um")}
        for line, name, value in entries:
            if name in running and abs(value - running[name]) > 1e-9:
                raise Refused("%s:%d: %s = %g, the running pool has %g (change the pool with swell-tool scene "
                              "load)" % (path, line, name, value, running[name]), 5)
        done: List[Tuple[str, int]] = []
        try:
            for line, name, value in entries:
                if name in running or name == "solver.hz":
                    continue
                before = self.params.raw(name)
                self.params[name] = value
                done.append((name, before))
                del line
        except Refused as e:
            for name, raw in reversed(done):
                self.params.set_raw(name, raw)
            raise Refused("%s: %s (%d set before it put back)" % (path, str(e), len(done)), e.error) from None
        return [n for n, _ in done]

    def wait_state(self, state: str, timeout: float = 5.0) -> None:
        end = time.monotonic() + timeout
        while self.state != state:
            if time.monotonic() > end:
                raise Timeout("state %s, not %s after %.1f s" % (self.state, state, timeout))
            self._pump(0.05)

    # ---- telemetry ----
    def stream(self) -> "Stream":
        """with c.stream() as s: for sample in s: ...; or s.to_numpy(seconds=5)."""
        return Stream(self)

    def record(self, path: str, seconds: float) -> int:
        """Records every frame of our node for `seconds` into a SWELLREC file; returns the count."""
        n = 0
        with RecordingWriter(path, self.link.carrier) as w:
            last = [None]

            def sink(_t: float, frame: Frame, _m: proto.Message) -> None:
                nonlocal n
                if frame is not last[0]:
                    w.write(frame)
                    last[0] = frame
                    n += 1
            self._sink = sink
            try:
                end = time.monotonic() + seconds
                while time.monotonic() < end:
                    self._pump(end - time.monotonic())
            finally:
                self._sink = None
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


class Stream:
    """Telemetry samples (OBJECT_POSE joined with the OBJECT_FORCE of the same seq) and heights."""

    def __init__(self, ctl: Controller):
        self.c = ctl
        self.pose: Optional[proto.Message] = None
        self.pose_t = 0.0
        self.lost = 0
        self._last_seq: Optional[int] = None
        self.grid = None

    def _grid_for(self, s: proto.Message) -> None:
        import numpy as np
        if self.grid is None or self.grid.shape != (s["ny"], s["nx"]):
            self.grid = np.zeros((s["ny"], s["nx"]), dtype=np.float32)

    def __enter__(self) -> "Stream":
        s = self.c.latest.get("SCENE")
        if s is not None:
            self._grid_for(s)
        self.c._sink = self._take
        self._ready: List[Sample] = []
        return self

    def __exit__(self, *exc) -> None:
        self.c._sink = None

    def _take(self, t: float, _frame: Frame, m: proto.Message) -> None:
        if m.name == "SCENE":
            self._grid_for(m)
        elif m.name == "OBJECT_POSE":
            self.pose, self.pose_t = m, t
        elif m.name == "OBJECT_FORCE" and self.pose is not None and self.pose["seq"] == m["seq"]:
            if self._last_seq is not None:
                self.lost += (m["seq"] - self._last_seq - 1) & 0xFF
            self._last_seq = m["seq"]
            p = self.pose
            self._ready.append(Sample(self.pose_t, m["seq"],
                                      tuple(p.physical(k) for k in ("x_10um", "y_10um", "z_10um")),
                                      p.physical("submersion_halfpct"),
                                      tuple(m.physical(k) for k in ("fx_cN", "fy_cN", "fz_cN"))))
        elif m.name == "HEIGHT_QUAD" and self.grid is not None:
            t_ = T.TILE
            y = m["tile_y"] * t_ + m["row"]
            x0 = m["tile_x"] * t_ + 4 * m["half"]
            if y < self.grid.shape[0]:
                for k, h in enumerate(proto.heights_mm(m)):
                    if x0 + k < self.grid.shape[1]:
                        self.grid[y, x0 + k] = h

    def __iter__(self) -> Iterator[Sample]:
        while True:
            while not self._ready:
                self.c._pump(self.c.timeout)
                if time.monotonic() - self.c._hb_time > max(self.c.timeout, SILENT_S):
                    raise Timeout("the controller went silent (no heartbeat for %.1f s)" % SILENT_S)
            yield self._ready.pop(0)

    def to_numpy(self, seconds: float):
        """Samples for `seconds` as a structured array: t (s since the first), seq, x, y, z (mm),
        submersion (%), fx, fy, fz (N). The latest heights are in .grid (mm, rows y, columns x)."""
        import numpy as np
        dt = np.dtype([("t", "f8"), ("seq", "u1"), ("x", "f4"), ("y", "f4"), ("z", "f4"),
                       ("submersion", "f4"), ("fx", "f4"), ("fy", "f4"), ("fz", "f4")])
        rows = []
        end = time.monotonic() + seconds
        it = iter(self)
        while time.monotonic() < end:
            s = next(it)
            rows.append((s.t, s.seq) + s.pose_mm + (s.submersion_pct,) + s.force_N)
        a = np.array(rows, dtype=dt)
        if len(a):
            a["t"] -= a["t"][0]
        return a


def connect(spec: str = "udp:127.0.0.1:%d" % T.UDP_PORT_CLIENTS, timeout: float = 2.0) -> Controller:
    """A controller on the link spec; NoController if none is heard within timeout seconds."""
    link = open_link(spec)
    try:
        return Controller(link, timeout)
    except BaseException:
        link.close()
        raise
