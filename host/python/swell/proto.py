"""The swell wire protocol in Python: message payloads, USB/UDP packets and CAN ids, read from the
generated tables (_tables.py, written by swell-protogen from the C message table), so that a layout
exists once. Decoders are strict like the C ones: a truncated, oversized, unknown, out-of-range,
reserved-bit, wrong-version or wrong-CRC input raises ProtocolError and yields nothing."""
from __future__ import annotations

import zlib
from dataclasses import dataclass, field
from decimal import Decimal
from typing import Dict, Iterable, List, Optional, Tuple

from . import _tables as T


class ProtocolError(ValueError):
    """A frame or packet the decoder refuses; the message says why (as the C decoder's reason)."""


@dataclass(frozen=True)
class Field:
    name: str
    start: int
    bits: int
    min: int
    max: int
    kind: str
    factor: Decimal
    unit: str

    @property
    def signed(self) -> bool:
        return self.min < 0


@dataclass(frozen=True)
class MessageType:
    name: str
    type: int
    length: int
    sender: str
    receiver: str
    fields: Tuple[Field, ...]


def _load() -> Tuple[Dict[str, MessageType], Dict[int, MessageType]]:
    by_name, by_type = {}, {}
    for name, mtype, length, sender, receiver, fields in T.MESSAGES:
        fs = tuple(Field(f[0], f[1], f[2], f[3], f[4], f[5], Decimal(f[6]), f[7]) for f in fields)
        mt = MessageType(name, mtype, length, sender, receiver, fs)
        by_name[name] = mt
        by_type[mtype] = mt
    return by_name, by_type


MESSAGES, MESSAGES_BY_TYPE = _load()


@dataclass
class Message:
    """One message: its type name, the node it comes from or goes to, and raw field values (integers
    in the unit their name says, e.g. fz_cN in 0.01 N); physical() gives them in SI-like units."""
    name: str
    node: int = 0
    raw: Dict[str, int] = field(default_factory=dict)

    @property
    def desc(self) -> MessageType:
        return MESSAGES[self.name]

    def __getitem__(self, key: str) -> int:
        return self.raw[key]

    def physical(self, key: str) -> float:
        """The field's value as raw * factor, in the field's unit (mm, N, mm/s, %)."""
        f = next(f for f in self.desc.fields if f.name == key)
        return float(self.raw[key] * f.factor)


def encode_payload(m: Message) -> bytes:
    """The payload bytes of m; ProtocolError if a field is missing or out of its raw range."""
    d = MESSAGES.get(m.name)
    if d is None:
        raise ProtocolError("unknown message %r" % m.name)
    word = 0
    for f in d.fields:
        if f.kind == "VERSION":
            v = m.raw.get(f.name, T.PROTO_VERSION)
        else:
            v = m.raw.get(f.name, 0)
        if not isinstance(v, int) or v < f.min or v > f.max:
            raise ProtocolError("%s.%s = %r is outside %d..%d" % (m.name, f.name, v, f.min, f.max))
        word |= (v & ((1 << f.bits) - 1)) << f.start
    return word.to_bytes(d.length, "little")


def decode_payload(mtype: int, payload: bytes, node: int = 0) -> Message:
    """The message of type mtype from exactly its payload bytes."""
    d = MESSAGES_BY_TYPE.get(mtype)
    if d is None:
        raise ProtocolError("unknown message type 0x%02X" % mtype)
    if len(payload) != d.length:
        raise ProtocolError("%s: %d bytes, not %d" % (d.name, len(payload), d.length))
    word = int.from_bytes(payload, "little")
    used = 0
    raw = {}
    for f in d.fields:
        mask = (1 << f.bits) - 1
        v = (word >> f.start) & mask
        used |= mask << f.start
        if f.signed and v >> (f.bits - 1):
            v -= 1 << f.bits
        if v < f.min or v > f.max:
            raise ProtocolError("%s.%s = %d is outside %d..%d" % (d.name, f.name, v, f.min, f.max))
        if f.kind == "VERSION" and v != T.PROTO_VERSION:
            raise ProtocolError("%s: protocol version %d, not %d" % (d.name, v, T.PROTO_VERSION))
        raw[f.name] = v
    if word & ~used:
        raise ProtocolError("%s: reserved bits set" % d.name)
    return Message(d.name, node, raw)


def can_id(m: Message) -> int:
    """The classic CAN identifier of m: type << 4 | node."""
    return MESSAGES[m.name].type << 4 | m.node


def can_decode(can_id_: int, data: bytes) -> Message:
    """The message of one classic CAN frame (11-bit id = type << 4 | node)."""
    if can_id_ > 0x7FF:
        raise ProtocolError("CAN id 0x%X is not an 11-bit id" % can_id_)
    return decode_payload(can_id_ >> 4, bytes(data), can_id_ & 0xF)


def packet_encode(node: int, seq: int, msgs: Iterable[Message]) -> bytes:
    """One USB/UDP packet: magic, version, node, seq, count, (type, payload)..., CRC-32 (LE)."""
    if not 0 <= node <= T.NODE_MAX:
        raise ProtocolError("node %d is outside 0..%d" % (node, T.NODE_MAX))
    body = b""
    count = 0
    for m in msgs:
        body += bytes([MESSAGES[m.name].type]) + encode_payload(m)
        count += 1
    if count == 0:
        raise ProtocolError("a packet needs at least one message")
    pkt = bytes([T.PKT_MAGIC, T.PROTO_VERSION, node, seq & 0xFF, count]) + body
    if len(pkt) + 4 > T.PKT_MAX:
        raise ProtocolError("%d messages do not fit one %d-byte packet" % (count, T.PKT_MAX))
    return pkt + zlib.crc32(pkt).to_bytes(4, "little")


def packet_decode(pkt: bytes) -> Tuple[int, int, List[Message]]:
    """(node, seq, messages) of one packet."""
    if len(pkt) < T.PKT_HEADER + 4:
        raise ProtocolError("packet of %d bytes is truncated" % len(pkt))
    if len(pkt) > T.PKT_MAX:
        raise ProtocolError("packet of %d bytes is oversized" % len(pkt))
    if zlib.crc32(pkt[:-4]) != int.from_bytes(pkt[-4:], "little"):
        raise ProtocolError("packet CRC mismatch")
    magic, version, node, seq, count = pkt[:5]
    if magic != T.PKT_MAGIC:
        raise ProtocolError("packet magic 0x%02X" % magic)
    if version != T.PROTO_VERSION:
        raise ProtocolError("packet protocol version %d, not %d" % (version, T.PROTO_VERSION))
    if node > T.NODE_MAX:
        raise ProtocolError("packet node %d" % node)
    pos, out, end = T.PKT_HEADER, [], len(pkt) - 4
    for _ in range(count):
        if pos >= end:
            raise ProtocolError("packet ends inside its records")
        d = MESSAGES_BY_TYPE.get(pkt[pos])
        if d is None:
            raise ProtocolError("unknown message type 0x%02X" % pkt[pos])
        if pos + 1 + d.length > end:
            raise ProtocolError("packet ends inside a %s" % d.name)
        out.append(decode_payload(d.type, pkt[pos + 1:pos + 1 + d.length], node))
        pos += 1 + d.length
    if pos != end or count == 0:
        raise ProtocolError("packet record count %d does not match its length" % count)
    return node, seq, out


def heights_mm(m: Message) -> Tuple[float, float, float, float]:
    """The four heights of a HEIGHT_QUAD in mm (the fields' factor from the table)."""
    return tuple(m.physical("h%d" % k) for k in range(4))  # type: ignore[return-value]


def state_name(code: int) -> str:
    return T.STATES.get(code, "?")


def error_text(code: int) -> str:
    return T.ERRORS.get(code, "unknown error")


def find_type(name: str) -> Optional[MessageType]:
    return MESSAGES.get(name)
