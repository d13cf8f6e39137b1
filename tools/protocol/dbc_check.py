#!/usr/bin/env python3
"""dbc_check.py: an independent decoder for the swell CAN database.

Parses a .dbc file (the subset swell-protogen writes: BO_ and SG_ lines, little-endian signals,
optional sign) with the standard library only, decodes every frame of a vectors file written by
the C encoder (swell-protogen --vectors) and compares each signal's physical value with the value
the C side put in. It shares no code with the C implementation.

Besides the C vectors, a few frames worked out by hand from docs/protocol.md (KNOWN below) must
decode to their stated values, so that C and DBC cannot agree on the same mistake.

Exit status 0 when every frame decodes to the same values and every message and signal of the
database was exercised; 1 otherwise, with the first differences printed.
"""
import argparse
import re
import sys

BO_RE = re.compile(r'^BO_\s+(\d+)\s+(\w+)\s*:\s*(\d+)\s+(\w+)')
SG_RE = re.compile(r'^\s*SG_\s+(\w+)\s*:\s*(\d+)\|(\d+)@([01])([+-])\s*'
                   r'\(\s*([-+0-9.eE]+)\s*,\s*([-+0-9.eE]+)\s*\)\s*'
                   r'\[\s*([-+0-9.eE]+)\s*\|\s*([-+0-9.eE]+)\s*\]\s*"([^"]*)"')


class Signal:
    def __init__(self, name, start, length, little, signed, factor, offset, lo, hi, unit):
        self.name, self.start, self.length = name, start, length
        self.little, self.signed = little, signed
        self.factor, self.offset, self.lo, self.hi, self.unit = factor, offset, lo, hi, unit

    def decode(self, data):
        if not self.little:
            raise ValueError(f'{self.name}: big-endian signals are not used by swell')
        word = int.from_bytes(data, 'little')
        raw = (word >> self.start) & ((1 << self.length) - 1)
        if self.signed and raw >> (self.length - 1):
            raw -= 1 << self.length
        return raw * self.factor + self.offset


def parse_dbc(path):
    messages = {}
    current = None
    with open(path, encoding='utf-8') as f:
        for lineno, line in enumerate(f, 1):
            m = BO_RE.match(line)
            if m:
                current = {'id': int(m.group(1)), 'name': m.group(2), 'dlc': int(m.group(3)),
                           'signals': {}}
                messages[current['id']] = current
                continue
            m = SG_RE.match(line)
            if m:
                if current is None:
                    raise ValueError(f'{path}:{lineno}: SG_ outside a BO_')
                s = Signal(m.group(1), int(m.group(2)), int(m.group(3)), m.group(4) == '1',
                           m.group(5) == '-', float(m.group(6)), float(m.group(7)),
                           float(m.group(8)), float(m.group(9)), m.group(10))
                if s.start + s.length > 8 * current['dlc']:
                    raise ValueError(f'{path}:{lineno}: {s.name} does not fit in {current["dlc"]} bytes')
                current['signals'][s.name] = s
                continue
    return messages


# (CAN id, payload, physical values): CTL_INFO of node 0, firmware 1.2.3, object 50.0 x 50.1 x
# 819.1 mm = 1 | 2 << 8 | 3 << 16 | 500 << 24 | 501 << 37 | 8191 << 50, little-endian.
KNOWN = [
    (0x230, bytes([0x01, 0x02, 0x03, 0xf4, 0xa1, 0x3e, 0xfc, 0x7f]),
     {'fw_major': 1, 'fw_minor': 2, 'fw_patch': 3,
      'obj_a_100um': 50.0, 'obj_b_100um': 50.1, 'obj_h_100um': 819.1}),
]


def check_known(db):
    errors = []
    for can_id, data, want in KNOWN:
        msg = db.get(can_id)
        if msg is None:
            errors.append(f'known frame 0x{can_id:03X} is not in the database')
            continue
        if set(want) != set(msg['signals']):
            errors.append(f'known frame {msg["name"]}: signals {sorted(msg["signals"])}, expected {sorted(want)}')
            continue
        for name, value in want.items():
            got = msg['signals'][name].decode(data)
            if abs(got - value) > 1e-9 * max(1.0, abs(value)):
                errors.append(f'known frame {msg["name"]}.{name}: DBC decodes {got!r}, by hand {value!r}')
    return errors


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('dbc', help='the CAN database (docs/swell.dbc)')
    ap.add_argument('vectors', help='frames from swell-protogen --vectors')
    args = ap.parse_args()

    db = parse_dbc(args.dbc)
    if not db:
        print(f'dbc_check: no messages in {args.dbc}')
        return 1
    seen_msgs, seen_sigs = set(), set()
    frames = values = 0
    errors = []
    with open(args.vectors, encoding='utf-8') as f:
        for lineno, line in enumerate(f, 1):
            if not line.strip() or line.startswith('#'):
                continue
            parts = line.split()
            can_id, data = int(parts[0], 16), bytes.fromhex(parts[1])
            expect = dict(p.split('=', 1) for p in parts[2:])
            msg = db.get(can_id)
            if msg is None:
                errors.append(f'line {lineno}: id 0x{can_id:03X} is not in the database')
                continue
            if len(data) != msg['dlc']:
                errors.append(f'line {lineno}: {msg["name"]} has {len(data)} bytes, DBC says {msg["dlc"]}')
                continue
            if set(expect) != set(msg['signals']):
                errors.append(f'line {lineno}: {msg["name"]} signals differ: C {sorted(expect)}, '
                              f'DBC {sorted(msg["signals"])}')
                continue
            frames += 1
            seen_msgs.add(can_id)
            for name, sig in msg['signals'].items():
                got = sig.decode(data)
                want = float(expect[name])
                values += 1
                seen_sigs.add((can_id, name))
                if abs(got - want) > 1e-9 * max(1.0, abs(want)):
                    errors.append(f'line {lineno}: {msg["name"]}.{name}: DBC decodes {got!r} {sig.unit}, '
                                  f'C encoded {want!r}')
                if not (sig.lo - 1e-9 <= got <= sig.hi + 1e-9):
                    errors.append(f'line {lineno}: {msg["name"]}.{name} = {got} outside the DBC range '
                                  f'[{sig.lo}, {sig.hi}]')
    errors += check_known(db)
    missing = [db[i]['name'] for i in db if i not in seen_msgs]
    all_sigs = {(i, n) for i in db for n in db[i]['signals']}
    if missing:
        errors.append(f'messages never exercised: {missing}')
    if all_sigs - seen_sigs:
        errors.append(f'signals never exercised: {sorted(all_sigs - seen_sigs)}')
    for e in errors[:20]:
        print('dbc_check:', e)
    print(f'dbc_check: {frames} frames, {values} signal values, {len(seen_msgs)}/{len(db)} messages, '
          f'{len(errors)} differences')
    return 1 if errors or frames == 0 else 0


if __name__ == '__main__':
    sys.exit(main())
