"""Bulk decoding with numpy: many received frames at once, as arrays, with the same checks as the
frame-by-frame codec in proto.py (and the C decoder): a packet with a wrong CRC, magic, version or
length, an unknown message type, a field outside its range or a reserved bit set is refused whole
and counted, never partly used. Telemetry comes at the controller's tick rate (2500 Hz, two or three
packets a tick); decoding it a message at a time in Python costs more than the tick, in bulk it
costs little (docs/benchmarks.md, "swell for Python")."""
from __future__ import annotations

import zlib
from dataclasses import dataclass
from typing import Dict

import numpy as np

from . import _tables as T
from . import proto

ROW = 80  # bytes a frame row holds: a packet's 64 and room to read 8 past any record


@dataclass
class Frames:
    """Received frames as rows: data[i, :length[i]] the bytes, t[i] the monotonic time of arrival
    (s), can_id[i] the CAN identifier (0 for packets)."""
    data: np.ndarray
    length: np.ndarray
    t: np.ndarray
    can_id: np.ndarray

    @staticmethod
    def empty(n: int) -> "Frames":
        return Frames(np.zeros((n, ROW), np.uint8), np.zeros(n, np.int32), np.zeros(n, np.float64),
                      np.zeros(n, np.uint32))

    def __len__(self) -> int:
        return len(self.length)

    def head(self, n: int) -> "Frames":
        return Frames(self.data[:n], self.length[:n], self.t[:n], self.can_id[:n])

    @staticmethod
    def concat(parts) -> "Frames":
        parts = [p for p in parts if len(p)]
        if not parts:
            return Frames.empty(0)
        return Frames(np.concatenate([p.data for p in parts]), np.concatenate([p.length for p in parts]),
                      np.concatenate([p.t for p in parts]), np.concatenate([p.can_id for p in parts]))


_LEN = np.zeros(256, np.int64)
for _d in proto.MESSAGES.values():
    _LEN[_d.type] = _d.length


@dataclass
class Decoded:
    """The messages of some frames: per message type name, a dict of arrays (each field's raw value,
    "t" the frame's arrival, "order" the message's place in the stream, "node"); and per frame its
    packet seq (-1 for CAN and refused frames), node and whether it was refused."""
    msgs: Dict[str, Dict[str, np.ndarray]]
    seq: np.ndarray
    node: np.ndarray
    refused: np.ndarray


def _fields(mtype: int, words: np.ndarray):
    """Raw field values of messages of one type from their payload words; and which are refused."""
    d = proto.MESSAGES_BY_TYPE[mtype]
    bad = np.zeros(len(words), bool)
    used = 0
    out = {}
    for f in d.fields:
        mask = (1 << f.bits) - 1
        v = ((words >> np.uint64(f.start)) & np.uint64(mask)).astype(np.int64)
        used |= mask << f.start
        if f.signed:
            v = np.where(v >> (f.bits - 1) != 0, v - (1 << f.bits), v)
        bad |= (v < f.min) | (v > f.max)
        if f.kind == "VERSION":
            bad |= v != T.PROTO_VERSION
        out[f.name] = v
    bad |= (words & np.uint64(~used & ((1 << (8 * d.length)) - 1))) != 0
    return out, bad


def _word(data: np.ndarray, rows: np.ndarray, start: np.ndarray, length: np.ndarray) -> np.ndarray:
    """The little-endian payload words at data[rows, start:start+length] (length <= 8)."""
    w = np.zeros(len(rows), np.uint64)
    for j in range(8):
        b = data[rows, np.minimum(start + j, ROW - 1)].astype(np.uint64)
        w |= np.where(j < length, b, 0).astype(np.uint64) << np.uint64(8 * j)
    return w


def decode(frames: Frames, carrier: str = "pkt") -> Decoded:
    """Every message of the frames of one carrier ("pkt" or "can")."""
    n = len(frames)
    refused = np.zeros(n, bool)
    seq = np.full(n, -1, np.int64)
    node = np.zeros(n, np.int64)
    if carrier == "pkt":
        data, ln = frames.data, frames.length.astype(np.int64)
        refused |= (ln < T.PKT_HEADER + 4) | (ln > T.PKT_MAX)
        for i in np.flatnonzero(~refused):  # the CRC: zlib's, a packet at a time (about 1 us each)
            L = int(ln[i])
            if zlib.crc32(data[i, :L - 4]) != int.from_bytes(data[i, L - 4:L].tobytes(), "little"):
                refused[i] = True
        refused |= (data[:, 0] != T.PKT_MAGIC) | (data[:, 1] != T.PROTO_VERSION) | (data[:, 2] > T.NODE_MAX)
        count = data[:, 4].astype(np.int64)
        refused |= count == 0
        end = ln - 4
        pos = np.full(n, T.PKT_HEADER, np.int64)
        rows_l, types_l, words_l, order_l = [], [], [], []
        for k in range(int(count[~refused].max()) if (~refused).any() else 0):
            act = np.flatnonzero(~refused & (k < count))
            if not len(act):
                break
            at = pos[act]
            inside = at < end[act]
            ty = np.where(inside, data[act, np.minimum(at, ROW - 1)], 0).astype(np.int64)
            L = _LEN[ty]
            bad = ~inside | (L == 0) | (at + 1 + L > end[act])
            refused[act[bad]] = True
            ok = act[~bad]
            rows_l.append(ok)
            types_l.append(ty[~bad])
            words_l.append(_word(data, ok, pos[ok] + 1, L[~bad]))
            order_l.append(ok * 64 + k)
            pos[ok] += 1 + L[~bad]
        refused |= pos != end
        rows = np.concatenate(rows_l) if rows_l else np.zeros(0, np.int64)
        types = np.concatenate(types_l) if types_l else np.zeros(0, np.int64)
        words = np.concatenate(words_l) if words_l else np.zeros(0, np.uint64)
        order = np.concatenate(order_l) if order_l else np.zeros(0, np.int64)
        node = data[:, 2].astype(np.int64)
        seq = np.where(refused, -1, data[:, 3].astype(np.int64))
        mnode = node[rows]
    elif carrier == "can":
        cid = frames.can_id.astype(np.int64)
        types = cid >> 4
        L = _LEN[np.minimum(types, 255)]
        refused |= (cid > 0x7FF) | (L == 0) | (frames.length != L)
        rows = np.flatnonzero(~refused)
        types = types[rows]
        words = _word(frames.data, rows, np.zeros(len(rows), np.int64), L[rows])
        order = rows * 64
        node = cid & 0xF
        mnode = node[rows]
    else:
        raise proto.ProtocolError("carrier %s is not decoded here" % carrier)
    msgs: Dict[str, Dict[str, np.ndarray]] = {}
    per_type = {}
    for ty in np.unique(types):
        sel = np.flatnonzero(types == ty)
        vals, bad = _fields(int(ty), words[sel])
        refused[rows[sel[bad]]] = True
        per_type[int(ty)] = (sel, vals)
    for ty, (sel, vals) in per_type.items():
        keep = ~refused[rows[sel]]  # a packet with one refused message is refused whole
        d = {k: v[keep] for k, v in vals.items()}
        d["t"] = frames.t[rows[sel[keep]]]
        d["order"] = order[sel[keep]]
        d["node"] = mnode[sel[keep]]
        msgs[proto.MESSAGES_BY_TYPE[ty].name] = d
    if carrier == "pkt":
        seq = np.where(refused, -1, seq)
    return Decoded(msgs, seq, node, refused)


def of_node(d: Dict[str, np.ndarray], node: int) -> Dict[str, np.ndarray]:
    sel = d["node"] == node
    return {k: v[sel] for k, v in d.items()}


def unwrap(seq: np.ndarray, modulo: int = 256) -> np.ndarray:
    """A counter modulo `modulo` as a count from its first value (steps shorter than a wrap)."""
    if not len(seq):
        return np.zeros(0, np.int64)
    return np.concatenate([[0], np.cumsum(np.diff(seq.astype(np.int64)) % modulo)])


def lost_by_seq(seq: np.ndarray, clock: np.ndarray = None, modulo: int = 256) -> int:
    """Frames missing from a stream of sequence numbers modulo `modulo`, in the order received. A gap
    of a wrap or more is told by a coarser clock that goes on in the frames (clock[i]: the frame's
    place on it, e.g. the number of object poses before it, 100 a second against 2500 ticks): the
    frames a step of the clock holds, measured over the whole stream, give how many wraps a gap hid.
    Without a clock a gap counts less than one wrap."""
    if len(seq) < 2:
        return 0
    gaps = (np.diff(seq.astype(np.int64)) - 1) % modulo
    if clock is not None and len(clock) == len(seq) and clock[-1] > clock[0]:
        per_step = (len(seq) + gaps.sum()) / float(clock[-1] - clock[0])
        expect = np.diff(clock) * per_step
        wraps = np.where(expect > modulo / 2, np.maximum(np.round((expect - gaps) / modulo), 0), 0)
        gaps = gaps + wraps.astype(np.int64) * modulo
    return int(gaps.sum())
