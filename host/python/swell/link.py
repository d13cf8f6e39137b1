"""Links to a controller: UDP (software in the loop, the clients' port of swell-ctl), SocketCAN
(classic frames through the kernel's AF_CAN sockets) and recordings (the SWELLREC file format that
the C links write). Each carries frames; a frame is (carrier, can_id, data): carrier "pkt" for USB/UDP
packets (can_id 0), "can" for classic CAN."""
from __future__ import annotations

import errno
import os
import socket
import struct
import time
from typing import BinaryIO, Iterator, List, Optional, Tuple

from . import _tables as T
from . import proto

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

    def send(self, frame: Frame) -> None:
        raise NotImplementedError

    def recv(self, timeout_s: float) -> Optional[Frame]:
        """The next frame, or None after timeout_s without one."""
        raise NotImplementedError

    def close(self) -> None:
        pass


class UdpLink(Link):
    """Packets as UDP datagrams to a controller's clients' port. Binds the first free of the tools'
    ports on loopback (the controller knows clients by address), any free port if all are taken."""
    carrier = "pkt"

    def __init__(self, host: str = T.UDP_HOST, port: int = T.UDP_PORT_CLIENTS):
        self.peer = (host, port)
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
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)

    def send(self, frame: Frame) -> None:
        try:
            self.sock.sendto(frame[2], self.peer)
        except OSError as e:
            raise LinkError("udp %s:%d: %s" % (self.peer[0], self.peer[1], e.strerror)) from e

    def recv(self, timeout_s: float) -> Optional[Frame]:
        end = time.monotonic() + max(timeout_s, 0.0)
        while True:
            self.sock.settimeout(max(end - time.monotonic(), 1e-4))  # 0 would make it non-blocking
            try:
                data, addr = self.sock.recvfrom(256)
            except (socket.timeout, BlockingIOError):
                return None
            except ConnectionRefusedError:
                return None  # an ICMP answer to an earlier datagram: nobody listens (yet)
            if addr == self.peer:  # a controller that admitted this port before still sends for 3 s
                return ("pkt", 0, data)

    def close(self) -> None:
        self.sock.close()


class CanLink(Link):
    """Classic CAN frames on a SocketCAN interface (can0, vcan0)."""
    carrier = "can"
    _FMT = struct.Struct("<IB3x8s")

    def __init__(self, iface: str):
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
        return ("can", can_id & socket.CAN_SFF_MASK, data[:dlc])

    def close(self) -> None:
        self.sock.close()


def open_link(spec: str) -> Link:
    """udp[:PORT] or udp:HOST:PORT, can:IFACE; the spellings of swell-tool's --link."""
    parts = spec.split(":")
    if parts[0] == "udp":
        try:
            if len(parts) == 1:
                return UdpLink()
            if len(parts) == 2:
                return UdpLink(port=int(parts[1]))
            if len(parts) == 3:
                return UdpLink(parts[1], int(parts[2]))
        except ValueError:
            pass
        raise LinkError("link '%s': udp[:PORT] or udp:HOST:PORT with a port number" % spec)
    if parts[0] == "can" and len(parts) == 2 and parts[1]:
        return CanLink(parts[1])
    raise LinkError("link '%s' is not one of udp[:PORT], udp:HOST:PORT, can:IFACE" % spec)


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
