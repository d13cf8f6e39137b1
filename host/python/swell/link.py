"""Links to a controller, spelled as swell-tool's --link: UDP (software in the loop, the clients' port
of swell-ctl), SocketCAN (classic frames through the kernel's AF_CAN sockets), USB (the controller's
host interface through python3-usb) and recordings (the SWELLREC file format of the C links, read and
written). Each carries frames; a frame is (carrier, can_id, data): carrier "pkt" for USB/UDP packets
(can_id 0), "can" for classic CAN. fill() takes many frames at once into numpy rows (bulk.Frames),
the way telemetry at the tick rate is received."""
from __future__ import annotations

import errno
import socket
import struct
import time
from typing import BinaryIO, Iterator, List, Optional, Tuple

import numpy as np

from . import _tables as T
from . import proto
from .bulk import ROW, Frames

Frame = Tuple[str, int, bytes]
CARRIERS = {0: "can", 1: "canfd", 2: "pkt"}
REC_MAGIC = b"SWELLREC"
REC_VERSION = 1
_REC_HEADER = struct.Struct("<8sIB3x")
_REC_FRAME = struct.Struct("<QIHBx")


class LinkError(OSError):
    """A link that cannot be opened, or went away; the message is the one-line reason."""


class RecordingError(ValueError):
    """A recording that is not one, or is cut: the message says where."""


class Link:
    carrier = "pkt"
    name = "?"  # as the C tools describe the link: "udp 127.0.0.1:47802", "can can0"
    keepalive = False  # the controller keeps this client only while it hears from it (UDP)

    def send(self, frame: Frame) -> None:
        raise NotImplementedError

    def recv(self, timeout_s: float) -> Optional[Frame]:
        """The next frame, or None after timeout_s without one."""
        raise NotImplementedError

    def fill(self, fr: Frames, start: int, deadline: float, wait_s: float, tick=None) -> int:
        """Frames into rows start.. of fr until fr is full, the monotonic deadline passes or none came
        for wait_s (0: only what is waiting now); returns the index after the last row filled.
        tick(now), if given, is called at least every 50 ms (the caller's keepalive)."""
        i, cap = start, len(fr)
        last = time.monotonic()
        while i < cap:
            now = time.monotonic()
            if tick:
                tick(now)
            if wait_s > 0 and (now >= deadline or now - last >= wait_s):
                break
            f = self.recv(min(deadline - now, 0.05) if wait_s > 0 else 0.0)
            if f is None and wait_s <= 0:
                break
            if f is None or len(f[2]) > 64:
                continue
            fr.data[i, :len(f[2])] = np.frombuffer(f[2], np.uint8)
            fr.length[i] = len(f[2])
            fr.can_id[i] = f[1]
            last = fr.t[i] = time.monotonic()
            i += 1
        return i

    def close(self) -> None:
        pass


class UdpLink(Link):
    """Packets as UDP datagrams to a controller's clients' port. Binds the first free of the tools'
    ports on loopback (the controller knows clients by address), any free port if all are taken."""
    carrier = "pkt"
    keepalive = True
    RCVBUF = 8 << 20  # bytes asked for: 1 s of the tick rate's telemetry and more

    def __init__(self, host: str = T.UDP_HOST, port: int = T.UDP_PORT_CLIENTS):
        self.peer = (host, port)
        self.name = "udp %s:%d" % (host, port)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        bind_host = "127.0.0.1" if host.startswith("127.") or host == "localhost" else ""
        for p in list(range(T.UDP_PORT_TOOLS_FIRST, T.UDP_PORT_TOOLS_FIRST + T.UDP_PORT_TOOLS_COUNT)) + [0]:
            try:
                self.sock.bind((bind_host, p))
                break
            except OSError as e:
                if e.errno != errno.EADDRINUSE or p == 0:
                    self.sock.close()
                    raise LinkError("udp: cannot bind a local port: %s" % e.strerror) from e
        # the receive buffer holds what comes while Python is elsewhere (a collection, a plot): beyond
        # net.core.rmem_max where allowed (SO_RCVBUFFORCE, CAP_NET_ADMIN), else up to it
        try:
            self.sock.setsockopt(socket.SOL_SOCKET, getattr(socket, "SO_RCVBUFFORCE", 33), self.RCVBUF)
        except OSError:
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, self.RCVBUF)
        self.rcvbuf = self.sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF)
        self._timeout = None

    def send(self, frame: Frame) -> None:
        try:
            self.sock.sendto(frame[2], self.peer)
        except OSError as e:
            raise LinkError("udp %s:%d: %s" % (self.peer[0], self.peer[1], e.strerror)) from e

    def _settimeout(self, s: float) -> None:
        if s != self._timeout:
            self.sock.settimeout(s)
            self._timeout = s

    def recv(self, timeout_s: float) -> Optional[Frame]:
        end = time.monotonic() + max(timeout_s, 0.0)
        while True:
            self._settimeout(max(end - time.monotonic(), 1e-4))  # 0 would make it non-blocking
            try:
                data, addr = self.sock.recvfrom(256)
            except (socket.timeout, BlockingIOError):
                return None
            except ConnectionRefusedError:
                return None  # an ICMP answer to an earlier datagram: nobody listens (yet)
            if addr == self.peer:  # a controller that admitted this port before still sends for 3 s
                return ("pkt", 0, data)

    def fill(self, fr: Frames, start: int, deadline: float, wait_s: float, tick=None) -> int:
        # the hot loop of a capture: one recvfrom_into a row and two stores a datagram, no decoding
        sock, peer, mono = self.sock, self.peer, time.monotonic
        flat = memoryview(fr.data.reshape(-1))
        length, t = fr.length, fr.t
        i, cap = start, len(fr)
        drain = wait_s <= 0  # only what is waiting now
        self._settimeout(0.0 if drain else 0.02)
        last = now = mono()
        due = now
        while i < cap and (drain or (now < deadline and now - last < wait_s)):
            if tick and now >= due:
                tick(now)
                due = now + 0.05
            try:
                n, addr = sock.recvfrom_into(flat[i * ROW:(i + 1) * ROW])
            except (socket.timeout, BlockingIOError):
                if drain:
                    break
                now = mono()
                continue
            except ConnectionRefusedError:  # an ICMP answer to an earlier datagram
                now = mono()
                continue
            now = mono()
            if addr == peer and n <= 64:  # longer ones are not swell packets (the C link drops them)
                length[i] = n
                t[i] = last = now
                i += 1
        return i

    def close(self) -> None:
        self.sock.close()


class CanLink(Link):
    """Classic CAN frames on a SocketCAN interface (can0, vcan0)."""
    carrier = "can"
    _FMT = struct.Struct("<IB3x8s")

    def __init__(self, iface: str):
        self.name = "can %s" % iface
        try:
            self.sock = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
            self.sock.bind((iface,))
        except OSError as e:
            raise LinkError("can %s: %s" % (iface, e.strerror or e)) from e

    def send(self, frame: Frame) -> None:
        data = frame[2]
        self.sock.send(self._FMT.pack(frame[1], len(data), data.ljust(8, b"\0")))

    def recv(self, timeout_s: float) -> Optional[Frame]:
        self.sock.settimeout(max(timeout_s, 1e-4))
        try:
            raw = self.sock.recv(16)
        except (socket.timeout, BlockingIOError):
            return None
        can_id, dlc, data = self._FMT.unpack(raw)
        if can_id & (socket.CAN_EFF_FLAG | socket.CAN_RTR_FLAG | socket.CAN_ERR_FLAG) or dlc > 8:
            return None  # not one of swell's frames (classic, 11-bit data frames)
        return ("can", can_id, data[:dlc])

    def close(self) -> None:
        self.sock.close()


class UsbLink(Link):
    """Packets on the controller's USB interface (vendor class, one bulk OUT and one bulk IN endpoint,
    read from its descriptor as the C link does) through python3-usb (libusb underneath)."""
    carrier = "pkt"

    def __init__(self, vid: int = T.USB_VID, pid: int = T.USB_PID, iface: int = 0, wait_s: float = 0.0):
        self.name = "usb %04x:%04x interface %d" % (vid, pid, iface)
        try:
            import usb.core
            import usb.util
        except ImportError:
            raise LinkError("cannot open %s: python3-usb is not installed (tools/setup installs it)"
                            % self.name) from None
        self._usb = usb
        end = time.monotonic() + wait_s
        while True:  # a controller that is plugged in (or resets) within the wait is taken
            try:
                dev = usb.core.find(idVendor=vid, idProduct=pid)
            except usb.core.NoBackendError:
                raise LinkError("cannot open %s: no libusb backend for python3-usb" % self.name) from None
            if dev is not None or time.monotonic() >= end:
                break
            time.sleep(0.1)
        if dev is None:
            raise LinkError("cannot open %s: No such device" % self.name)
        try:
            if dev.is_kernel_driver_active(iface):
                dev.detach_kernel_driver(iface)
            intf = dev.get_active_configuration()[(iface, 0)]
            usb.util.claim_interface(dev, iface)
        except (usb.core.USBError, KeyError, NotImplementedError) as e:
            raise LinkError("cannot open %s: %s" % (self.name, e)) from None

        def ep(direction):
            return usb.util.find_descriptor(intf, custom_match=lambda e: usb.util.endpoint_type(e.bmAttributes)
                                            == usb.util.ENDPOINT_TYPE_BULK
                                            and usb.util.endpoint_direction(e.bEndpointAddress) == direction)
        self.dev, self.iface = dev, iface
        self.ep_out, self.ep_in = ep(usb.util.ENDPOINT_OUT), ep(usb.util.ENDPOINT_IN)
        if self.ep_out is None or self.ep_in is None:
            self.close()
            raise LinkError("cannot open %s: the interface has no bulk IN and OUT endpoints" % self.name)

    def send(self, frame: Frame) -> None:
        try:
            self.ep_out.write(frame[2], timeout=100)
        except self._usb.core.USBError as e:
            raise LinkError("%s: %s" % (self.name, e)) from e

    def recv(self, timeout_s: float) -> Optional[Frame]:
        try:
            data = self.ep_in.read(64, timeout=max(1, int(timeout_s * 1000)))
        except self._usb.core.USBTimeoutError:
            return None
        except self._usb.core.USBError:
            time.sleep(min(timeout_s, 0.01))  # unplugged: wait out the time, do not spin
            return None
        return ("pkt", 0, bytes(data))

    def close(self) -> None:
        try:
            self._usb.util.release_interface(self.dev, self.iface)
            self._usb.util.dispose_resources(self.dev)
        except self._usb.core.USBError:
            pass


LINKS = "udp[:PORT], udp:HOST:PORT, can:IFACE, usb[:VID:PID]"


def _refuse(spec: str, why: str) -> LinkError:
    return LinkError("'%s': %s" % (spec, why))


def _hex16(s: str) -> int:
    if not 1 <= len(s) <= 4 or any(c not in "0123456789abcdefABCDEF" for c in s):
        raise ValueError(s)
    return int(s, 16)


def open_link(spec: str, wait_s: float = 0.0) -> Link:
    """A link from its spelling, swell-tool's --link: udp[:PORT] (127.0.0.1, default port 47802),
    udp:HOST:PORT, can:IFACE, usb[:VID:PID] (waits up to wait_s for a USB device to appear). A bad
    spelling raises LinkError "'SPEC': reason", as the C parser words it."""
    parts = spec.split(":")
    if parts[0] == "udp":
        try:
            if len(parts) == 1:
                return UdpLink()
            if len(parts) == 2:
                port = int(parts[1]) if parts[1].isdigit() else 0
                if not 1 <= port <= 65535:
                    raise _refuse(spec, "UDP port not in 1..65535")
                return UdpLink(port=port)
            if len(parts) == 3:
                socket.inet_aton(parts[1])
                port = int(parts[2]) if parts[2].isdigit() else 0
                if not 1 <= port <= 65535:
                    raise _refuse(spec, "UDP port not in 1..65535")
                return UdpLink(parts[1], port)
        except OSError as e:
            if isinstance(e, LinkError):
                raise
        raise _refuse(spec, "not udp[:PORT] or udp:HOST:PORT (HOST a dotted IPv4 address)")
    if parts[0] == "can":
        if len(parts) != 2 or not parts[1]:
            raise _refuse(spec, "give the CAN interface, e.g. can:can0")
        if len(parts[1]) >= 16 or any(c in parts[1] for c in "/ \t\n,") or parts[1] in (".", ".."):
            raise _refuse(spec, "not an interface name (the node is chosen with --node)")
        return CanLink(parts[1])
    if parts[0] == "canfd":
        raise _refuse(spec, "swell's controller links are classic CAN (swell-ctl's can:IFACE, the F405's bxCAN): "
                      "use can:IFACE")
    if parts[0] == "usb":
        if len(parts) == 1:
            return UsbLink(wait_s=wait_s)
        try:
            if len(parts) == 3:
                return UsbLink(_hex16(parts[1]), _hex16(parts[2]), wait_s=wait_s)
        except ValueError:
            pass
        raise _refuse(spec, "not usb:VID:PID in hex")
    raise _refuse(spec, "not a link: " + LINKS)


def encode(link_carrier: str, node: int, seq: int, m: proto.Message) -> Frame:
    """One message as a frame of the carrier."""
    if link_carrier == "can":
        return ("can", proto.can_id(m), proto.encode_payload(m))
    return ("pkt", 0, proto.packet_encode(node, seq, [m]))


def decode(frame: Frame) -> List[proto.Message]:
    """The messages of one frame (ProtocolError if it is refused)."""
    carrier, can_id, data = frame
    if carrier == "can":
        return [proto.can_decode(can_id, data)]
    if carrier == "pkt":
        return proto.packet_decode(data)[2]
    raise proto.ProtocolError("carrier %s is not decoded here" % carrier)


class RecordingWriter:
    """Writes a SWELLREC recording, flushed per frame (a crash loses nothing already written)."""

    def __init__(self, path: str, carrier: str = "pkt"):
        code = {v: k for k, v in CARRIERS.items()}.get(carrier)
        if code is None:
            raise RecordingError("carrier %r is not one of %s" % (carrier, ", ".join(CARRIERS.values())))
        self.f: BinaryIO = open(path, "wb")
        self.f.write(_REC_HEADER.pack(REC_MAGIC, REC_VERSION, code))
        self.t0 = time.monotonic_ns()

    def write(self, frame: Frame, t_ns: Optional[int] = None) -> None:
        t = time.monotonic_ns() - self.t0 if t_ns is None else t_ns
        self.f.write(_REC_FRAME.pack(t, frame[1], len(frame[2]), 0) + frame[2])
        self.f.flush()

    def write_frames(self, fr: Frames) -> None:
        """Frames received by fill(), with their times of arrival, in one write."""
        if not len(fr):
            return
        ns = ((fr.t - self.t0 / 1e9) * 1e9).astype(np.int64).clip(0)
        out = bytearray()
        for i in range(len(fr)):
            n = int(fr.length[i])
            out += _REC_FRAME.pack(int(ns[i]), int(fr.can_id[i]), n, 0) + fr.data[i, :n].tobytes()
        self.f.write(out)
        self.f.flush()

    def close(self) -> None:
        self.f.close()

    def __enter__(self) -> "RecordingWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def read_recording(path: str) -> Tuple[str, Iterator[Tuple[int, Frame]]]:
    """(carrier, iterator of (ns since the start, frame)). A file that is not a recording raises
    RecordingError at once; a cut one raises it when the iterator reaches the cut, after every whole
    frame before it."""
    try:
        f = open(path, "rb")
    except OSError as e:
        raise RecordingError("%s: %s" % (path, e.strerror)) from e
    head = f.read(_REC_HEADER.size)
    if len(head) < _REC_HEADER.size or head[:8] != REC_MAGIC:
        f.close()
        raise RecordingError("%s: not a swell recording (no SWELLREC header)" % path)
    _, version, code = _REC_HEADER.unpack(head)
    if version != REC_VERSION or code not in CARRIERS:
        f.close()
        raise RecordingError("%s: recording format %d, carrier %d: not readable here" % (path, version, code))
    carrier = CARRIERS[code]

    def frames() -> Iterator[Tuple[int, Frame]]:
        n = 0
        with f:
            while True:
                hdr = f.read(_REC_FRAME.size)
                if not hdr:
                    return
                if len(hdr) < _REC_FRAME.size:
                    raise RecordingError("%s: cut inside the header of frame %d" % (path, n + 1))
                t, can_id, length, _flags = _REC_FRAME.unpack(hdr)
                if length > 64:
                    raise RecordingError("%s: frame %d claims %d bytes" % (path, n + 1, length))
                data = f.read(length)
                if len(data) < length:
                    raise RecordingError("%s: cut inside frame %d (%d of %d bytes)" % (path, n + 1, len(data), length))
                n += 1
                yield t, (carrier, can_id, data)
    return carrier, frames()
