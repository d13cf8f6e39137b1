"""The Python package against the C encoders and a live swell-ctl + swell-hm loop."""
import os
import re
import subprocess
import sys
from decimal import Decimal

import numpy as np
import pytest

from conftest import BIN, HERE, Loop, free_udp_port

import swell
from swell import proto
from swell.link import RecordingWriter, read_recording


# ---- codecs, against the C encoder ----
def test_every_message_decodes_to_the_values_the_c_encoder_put_in(tmp_path):
    vec = tmp_path / "vectors.txt"
    subprocess.run([os.path.join(BIN, "swell-protogen"), "--vectors", str(vec), "--count", "50", "--seed", "3"],
                   check=True, capture_output=True)
    n, names = 0, set()
    for line in vec.read_text().splitlines():
        if line.startswith("#"):
            continue
        parts = line.split()
        can_id, data = int(parts[0], 16), bytes.fromhex(parts[1])
        m = proto.can_decode(can_id, data)
        names.add(m.name)
        for kv in parts[2:]:
            k, v = kv.split("=")
            f = next(f for f in m.desc.fields if f.name == k)
            assert Decimal(m.raw[k]) * f.factor == Decimal(v), (m.name, k, m.raw[k], v)
        assert proto.encode_payload(m) == data  # and back to the same bytes
        n += 1
    assert names == set(proto.MESSAGES)
    assert n == 50 * len(proto.MESSAGES)


def frames_of(rows):
    """bulk.Frames of (can_id, bytes) rows."""
    from swell import bulk
    fr = bulk.Frames.empty(len(rows))
    for i, (cid, data) in enumerate(rows):
        fr.data[i, :len(data)] = np.frombuffer(data, np.uint8)
        fr.length[i], fr.can_id[i], fr.t[i] = len(data), cid, i
    return fr


def test_the_bulk_decoder_gives_what_the_message_decoder_gives_and_refuses_what_it_refuses(tmp_path):
    from swell import bulk
    import random
    vec = tmp_path / "vectors.txt"
    subprocess.run([os.path.join(BIN, "swell-protogen"), "--vectors", str(vec), "--count", "20", "--seed", "5"],
                   check=True, capture_output=True)
    rows = [(int(ln.split()[0], 16), bytes.fromhex(ln.split()[1])) for ln in vec.read_text().splitlines()
            if not ln.startswith("#")]
    rows.append((0x220, bytes(7) + b"\x80"))  # OBJECT_FORCE with a reserved bit: refused
    rows.append((0x7F0, bytes(8)))  # an unknown type: refused
    dec = bulk.decode(frames_of(rows), "can")
    want = [(i, proto.can_decode(cid, d)) for i, (cid, d) in enumerate(rows[:-2])]
    assert list(dec.refused) == [False] * (len(rows) - 2) + [True, True]
    for name, d in dec.msgs.items():
        mine = [(int(d["order"][k]) // 64, {f: int(d[f][k]) for f in d if f not in ("t", "order", "node")})
                for k in range(len(d["order"]))]
        assert mine == [(i, m.raw) for i, m in want if m.name == name]
    # packets of several messages; damaged copies refused whole, the good ones unchanged
    rnd = random.Random(7)
    msgs = [m for _, m in want]
    pkts = []
    for k in range(300):
        group = rnd.sample(msgs, rnd.randint(1, 5))
        try:
            pkts.append(proto.packet_encode(3, k & 0xFF, group))
        except proto.ProtocolError:
            pass  # more than a packet holds
    bad = [pkts[0][:-1] + bytes([pkts[0][-1] ^ 1]), pkts[1][:9], bytes([pkts[2][0], 9]) + pkts[2][2:]]
    dec = bulk.decode(frames_of([(0, p) for p in pkts + bad]), "pkt")
    assert not dec.refused[:len(pkts)].any() and dec.refused[len(pkts):].all()
    assert list(dec.seq[:len(pkts)]) == [p[3] for p in pkts]
    got = sorted((int(d["order"][k]), name, tuple(int(d[f.name][k]) for f in proto.MESSAGES[name].fields))
                 for name, d in dec.msgs.items() for k in range(len(d["order"])))
    ref = sorted((i * 64 + j, m.name, tuple(m.raw[f.name] for f in m.desc.fields))
                 for i, p in enumerate(pkts) for j, m in enumerate(proto.packet_decode(p)[2]))
    assert got == ref


def test_packets_round_trip_and_every_damaged_one_is_refused():
    msgs = [proto.Message("OBJECT_POSE", 3, {"x_10um": 20000, "y_10um": -5, "z_10um": -3937,
                                             "submersion_halfpct": 157, "seq": 9}),
            proto.Message("PARAM_GET", 3, {"id": 14, "seq": 200})]
    pkt = proto.packet_encode(3, 77, msgs)
    node, seq, back = proto.packet_decode(pkt)
    assert (node, seq) == (3, 77)
    assert [(m.name, m.raw) for m in back] == [(m.name, m.raw) for m in msgs]
    assert back[0].physical("z_10um") == pytest.approx(-39.37)
    bad = {"crc": pkt[:-1] + bytes([pkt[-1] ^ 1]), "truncated": pkt[:8], "empty": b"",
           "version": bytes([pkt[0], 9]) + pkt[2:], "oversized": pkt + bytes(64)}
    for why, b in bad.items():
        with pytest.raises(swell.ProtocolError):
            proto.packet_decode(b)
    with pytest.raises(swell.ProtocolError, match="outside"):
        proto.encode_payload(proto.Message("FORCE_CMD", 0, {"fz_cN": 25001}))
    with pytest.raises(swell.ProtocolError, match="reserved"):
        proto.decode_payload(0x22, bytes(7) + b"\x80")  # OBJECT_FORCE's top bits are reserved


def test_a_recording_reads_back_and_a_cut_one_says_where(tmp_path):
    path = str(tmp_path / "r.rec")
    frames = [("pkt", 0, bytes([i]) * (5 + i)) for i in range(10)]
    with RecordingWriter(path) as w:
        for i, f in enumerate(frames):
            w.write(f, t_ns=1000 * i)
    carrier, it = read_recording(path)
    assert carrier == "pkt"
    assert [(t, f) for t, f in it] == [(1000 * i, f) for i, f in enumerate(frames)]
    whole = open(path, "rb").read()
    open(path, "wb").write(whole[:-3])
    got = []
    with pytest.raises(swell.RecordingError, match="cut inside frame 10"):
        for _t, f in read_recording(path)[1]:
            got.append(f)
    assert got == frames[:9]  # every whole frame before the cut
    open(path, "wb").write(b"not a recording at all")
    with pytest.raises(swell.RecordingError, match="not a swell recording"):
        read_recording(path)


# ---- a live loop ----
def test_info_state_and_every_parameter_as_swell_tool_sees_it(loop):
    with swell.connect(loop.link) as c:
        i = c.info
        assert i.grid == (64, 64) and i.dx_mm == 6.25 and i.object_mm == (50.0, 50.0, 50.0)
        assert c.state in ("armed", "running")
        e = c.energy  # the account of the run: nothing created while the object hangs in the air
        assert isinstance(e, swell.Energy) and e.created_mJ == 0.0 and e.passivity  # on by default
        for name, p in swell.PARAMS.items():
            rc, out = loop.tool("get", name)
            assert rc == 0, out
            raw = int(re.search(r"\(raw (-?\d+)\)", out).group(1)) if "(raw" in out else None
            mine = c.params.raw(name)
            if raw is None:  # printed without a raw figure: the value itself is raw (factor 1)
                raw = int(re.search(r"= (-?\d+)", out).group(1))
            if name.startswith("dev.") or name == "dev.rate":
                continue  # measured every tick: the two reads are moments apart
            assert mine == raw, (name, mine, out)
            assert c.params[name] == pytest.approx(float(Decimal(raw) * p.factor))


def test_bad_input_is_a_clear_exception_and_leaves_the_controller_untouched(loop):
    with swell.connect(loop.link) as c:
        before = c.params.raw("wave.damping")
        with pytest.raises(swell.UnknownParameter, match="no parameter 'body.nope'; there are: wave.e"):
            c.params["body.nope"] = 1
        with pytest.raises(swell.UnknownParameter):
            c.params["body.nope"]
        with pytest.raises(swell.Refused) as e:
            c.params["wave.damping"] = 1.5  # over the table's 1
        assert (e.value.error, e.value.reason) == (2, "parameter out of range")
        assert str(e.value).startswith("set wave.damping refused by the controller: parameter out of range (state "
                                       "running); wave.damping stays ")
        with pytest.raises(swell.Refused, match="not allowed in this state"):
            c.params["body.mass"] = "0.1 kg"  # the object floats: its mass is fixed while it displaces water
        with pytest.raises(swell.Refused, match="not allowed in this state"):
            c.params["body.damper"] = 16.5  # likewise
        with pytest.raises(swell.BadValue, match="unit 'furlongs' is not g"):
            c.params["body.mass"] = "80 furlongs"
        with pytest.raises(swell.BadValue, match="read only"):
            c.params["dev.rate"] = 3
        assert c.params.raw("wave.damping") == before
        assert c.params["body.mass"] == 100
        assert c.params["body.damper"] == 15
        c.params["wave.damping"] = 0.002
        assert c.params["wave.damping"] == pytest.approx(0.002, abs=1e-9)
        c.params["force.max"] = "950 cN"  # a unit with another prefix
        assert c.params.raw("force.max") == 9500000
        c.params["force.max"] = 10
        c.params.set_raw("wave.damping", before)
        assert c.params.raw("wave.damping") == before


def test_a_dead_link_raises_no_controller_within_its_timeout():
    import time
    port = free_udp_port()
    t = time.monotonic()
    with pytest.raises(swell.NoController, match="no controller heard on udp 127.0.0.1:%d within 500 ms" % port):
        swell.connect("udp:127.0.0.1:%d" % port, timeout=0.5)
    assert time.monotonic() - t < 2.0
    for spec, why in (("tcp:1", "'tcp:1': not a link: udp"), ("udp:0", "'udp:0': UDP port not in 1..65535"),
                      ("can:", "give the CAN interface"), ("canfd:can0", "classic CAN"),
                      ("usb:12345:1", "not usb:VID:PID in hex")):
        with pytest.raises(swell.LinkError, match=why):
            swell.connect(spec)


def test_usb_without_a_controller_plugged_in_says_so():
    with pytest.raises(swell.LinkError, match="cannot open usb 1209:0001 interface 0: "):
        swell.connect("usb", timeout=0.2)


def test_telemetry_into_numpy_and_a_recording_of_it(loop, tmp_path):
    with swell.connect(loop.link) as c:
        with c.stream() as s:
            a = s.to_numpy(seconds=1.0)
            assert s.grid is not None and s.grid.shape == (64, 64)
            first = next(iter(s))
        assert a.samples.dtype.names == ("t", "seq", "x", "y", "z", "submersion", "fx", "fy", "fz", "limits")
        # 100 samples and 2500 ticks a second when the controller keeps time; the loss is the bench's
        # (label bench): here the count of what came and what is missing by sequence number
        assert 20 <= len(a) <= 102 and a.packets > 500
        assert a.lost_samples == int(((np.diff(a["seq"].astype(int)) - 1) % 256).sum())
        assert np.all(np.diff(a["t"]) >= 0)
        assert np.all((a["submersion"] > 50) & (a["submersion"] <= 100))  # the object floats
        assert a.heights.shape == (10, 64, 64) and np.allclose(a.heights_t, np.arange(1, 11) / 10)
        # the energy account, 10 a second: the same figures c.energy reads, never below zero created
        assert 5 <= len(a.energy) <= 12 and np.all(np.diff(a.energy["t"]) > 0)
        assert np.all(a.energy["created_mJ"] >= 0) and np.all(np.diff(a.energy["created_mJ"]) >= 0)
        assert np.isfinite(a.heights[-1]).all()  # every cell heard within a second
        assert abs(float(np.nanmean(a.heights[-1]))) < 5  # mm around the rest level
        assert set(a.states["state"]) == {3} and 2 <= len(a.states) <= 11  # running, 10 heartbeats a second
        assert isinstance(first, swell.Sample) and first.submersion_pct > 50
        n = c.record(str(tmp_path / "t.rec"), 0.5)
    assert n > 100  # the tick rate's packets
    carrier, it = read_recording(str(tmp_path / "t.rec"))
    kinds, frames = set(), 0
    for _t, f in it:
        frames += 1
        for m in swell.link.decode(f):
            kinds.add(m.name)
    assert frames == n
    assert {"HEARTBEAT", "OBJECT_POSE", "OBJECT_FORCE", "HEIGHT_QUAD"} <= kinds
    # the C reader takes the whole recording: every frame, none refused
    p = subprocess.run([os.path.join(BIN, "swell-linktest"), "replay", str(tmp_path / "t.rec"), "--fast"],
                       capture_output=True, text=True, timeout=30)
    assert p.returncode == 0, p.stderr
    assert re.search(r": %d frames, \d+ messages of \d+ types, 0 rejected" % n, p.stdout), p.stdout


def test_a_recording_the_c_link_wrote_reads_frame_for_frame(tmp_path):
    rec = str(tmp_path / "c.rec")
    p = subprocess.run([os.path.join(BIN, "swell-linktest"), "udp-pair", "--count", "300", "--record", rec],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stdout + p.stderr
    p = subprocess.run([os.path.join(BIN, "swell-linktest"), "replay", rec, "--fast"], capture_output=True,
                       text=True, timeout=30)
    want = re.search(r": (\d+) frames, (\d+) messages", p.stdout)
    carrier, it = read_recording(rec)
    assert carrier == "pkt"
    frames = msgs = 0
    last = -1
    for t, f in it:
        assert t >= last
        last = t
        frames += 1
        msgs += len(swell.link.decode(f))
    assert (frames, msgs) == (int(want.group(1)), int(want.group(2)))


def test_python_m_swell_speaks_like_swell_tool(loop):
    env = dict(os.environ, PYTHONPATH=os.path.dirname(HERE))
    run = lambda *a: subprocess.run([sys.executable, "-m", "swell", "--link", loop.link] + list(a),
                                    capture_output=True, text=True, env=env, timeout=30)
    p = run("get", "body.damper")
    assert p.returncode == 0 and re.match(r"body.damper = [0-9.]+ N\*s/m", p.stdout), p.stdout + p.stderr
    p = run("get", "body.nope")
    assert p.returncode == 2 and "no parameter 'body.nope'" in p.stderr
    p = run("set", "force.max", "2000", "N")
    assert p.returncode == 6 and "refused by the controller: parameter out of range" in p.stderr
    p = run("set", "force.max", "9", "furlongs")
    assert p.returncode == 2 and "unit 'furlongs' is not N" in p.stderr
    p = subprocess.run([sys.executable, "-m", "swell", "--link", "udp:127.0.0.1:%d" % free_udp_port(),
                        "--timeout", "0.3", "info"], capture_output=True, text=True, env=env, timeout=30)
    assert p.returncode == 3 and "no controller heard" in p.stderr


def test_the_worked_example_drops_records_plots_and_rests_within_half_a_percent(tmp_path):
    lp = Loop(str(tmp_path))
    try:
        import time
        time.sleep(6)  # the hand lets go at 0.5 s; the float settles within a few seconds
        png = str(tmp_path / "drop.png")
        env = dict(os.environ, PYTHONPATH=os.path.dirname(HERE))
        p = subprocess.run([sys.executable, os.path.join(HERE, "..", "examples", "drop_and_plot.py"),
                            "--link", lp.link, "--out", png], capture_output=True, text=True, env=env, timeout=60)
        print(p.stdout + p.stderr)
        assert p.returncode == 0, p.stdout + p.stderr
        assert open(png, "rb").read(8) == b"\x89PNG\r\n\x1a\n"
        assert os.path.getsize(png) > 10000
    finally:
        lp.stop()


def test_a_scene_file_is_one_change_or_none(loop, tmp_path):
    ok = tmp_path / "ok.scene"
    ok.write_text("# damping and limits, settable while the object floats\npool.nx = 64 cells\n"
                  "pool.dx = 6.25 mm\nwave.damping = 0.002\nforce.max = 900 cN\nforce.rate = 0.4 kN/s\n")
    bad = tmp_path / "bad.scene"
    bad.write_text("wave.damping = 0.003\nforce.max = 8 N\nbody.mass = 80 g\n")
    other = tmp_path / "other.scene"
    other.write_text("pool.nx = 128 cells\nwave.damping = 0.004\n")
    with swell.connect(loop.link) as c:
        d0, f0, r0 = (c.params.raw(n) for n in ("wave.damping", "force.max", "force.rate"))
        assert c.load_scene(str(ok)) == ["wave.damping", "force.max", "force.rate"]
        assert c.params["wave.damping"] == pytest.approx(0.002, abs=1e-9)
        assert c.params["force.max"] == pytest.approx(9.0)
        assert c.params["force.rate"] == pytest.approx(400.0)
        mid = [c.params.raw(n) for n in ("wave.damping", "force.max")]
        with pytest.raises(swell.Refused, match="not allowed in this state.*2 set before it put back"):
            c.load_scene(str(bad))  # the object floats: body.mass is refused, the two before it undone
        assert [c.params.raw(n) for n in ("wave.damping", "force.max")] == mid
        with pytest.raises(swell.BadValue, match="the running pool has 64"):
            c.load_scene(str(other))
        assert [c.params.raw(n) for n in ("wave.damping", "force.max")] == mid
        for n, raw in (("wave.damping", d0), ("force.max", f0), ("force.rate", r0)):
            c.params.set_raw(n, raw)
    for text, why in (("wave.damping 0.1\n", "not 'name = value unit'"), ("body.mass = 80 furlongs\n", "unit"),
                      ("body.colour = 3\n", "unknown key")):
        (tmp_path / "x.scene").write_text(text)
        with pytest.raises(ValueError, match=why):
            swell.client.parse_scene(str(tmp_path / "x.scene"))


def test_estop_stops_the_force_law_and_autorun_stays_off_until_asked(tmp_path):
    lp = Loop(str(tmp_path))
    try:
        lp.wait_floating()
        with swell.connect(lp.link) as c:
            assert c.state == "running"
            c.estop()
            c.wait_state("armed", 2.0)
            assert c.params["ctl.autorun"] == 0
            with c.stream() as s:
                a = s.to_numpy(seconds=0.5)
            assert len(a) > 20 and np.all(a["fz"][len(a) // 2:] == 0)  # no force while stopped
            c.start()
            c.wait_state("running", 2.0)
    finally:
        lp.stop()


# ---- check, against swell-tool check on the same chain ----
def lines_of_tool(out):
    """swell-tool check's lines as (verdict, name, text)."""
    rows = []
    for line in out.splitlines():
        if line[:5].strip() in ("ok", "FAIL", "skip"):
            rows.append((line[:5].strip(), line[6:17].strip(), line[18:]))
    return rows


def same_verdicts(mine, out):
    """Both tools' verdicts, names and fix texts, line for line."""
    theirs = lines_of_tool(out)
    assert [(x.verdict, x.name) for x in mine.lines] == [(v, n) for v, n, _ in theirs], (str(mine), out)
    for x, (v, n, text) in zip(mine.lines, theirs):
        assert x.fix == (text.split("fix: ", 1)[1] if "fix: " in text else ""), (x, text)


def agree(mine, out):
    theirs = lines_of_tool(out)
    return [(x.verdict, x.name, x.fix) for x in mine.lines] == \
        [(v, n, t.split("fix: ", 1)[1] if "fix: " in t else "") for v, n, t in theirs]


def agreeing(run_both, failed=None, tries=3):
    """Both checks, taken again (up to tries times) until they see the same chain, and the chain as it
    was set up (failed: the names that fail): the device's rate, the round trip and a fault on a late
    tick are wall-clock matters, and on a loaded machine two runs a moment apart can fall on each side
    of a bound. Returns the last pair."""
    for _ in range(tries):
        mine, rc, out = run_both()
        if agree(mine, out) and (failed is None or [x.name for x in mine.failed] == failed):
            break
    return mine, rc, out


def test_check_gives_swell_tool_checks_verdicts_good_and_failing(loop):
    limits = ("--max-force", "10", "--max-rate", "500", "--max-rtt-ms", "100")
    mine, rc, out = agreeing(lambda: (swell.check(loop.link, 1.0, max_force_N=10, max_rate_N_s=500, max_rtt_ms=100),)
                             + loop.tool("check", *limits), [])
    assert rc == 0 and mine.ok, (out, str(mine))
    same_verdicts(mine, out)
    assert [x.verdict for x in mine.lines] == ["ok"] * 7 + ["skip"]
    assert str(mine).splitlines()[-1] == out.splitlines()[-1] == "check: 7 passed, 0 failed, 1 skipped"
    assert mine["frame"].text == lines_of_tool(out)[4][2]  # the handle's place, the same figures
    assert loop.tool("set", "force.max", "30N")[0] == 0
    try:
        env = dict(os.environ, PYTHONPATH=os.path.dirname(HERE))
        p = subprocess.run([sys.executable, "-m", "swell", "--link", loop.link, "--timeout", "1", "check"]
                           + list(limits), capture_output=True, text=True, env=env, timeout=60)
        with swell.connect(loop.link) as c:
            mine, rc, out = agreeing(lambda: (c.check(max_force_N=10, max_rate_N_s=500, max_rtt_ms=100),)
                                     + loop.tool("check", *limits), ["force"])
            assert c.params["force.max"] == 30  # a check reads, never writes
    finally:
        assert loop.tool("set", "force.max", "10N")[0] == 0
    assert rc == 7 and not mine.ok and [x.name for x in mine.failed] == ["force"]
    assert mine["force"].text.startswith("force.max 30 N, force.rate 500 N/s, above 10 N, 500 N/s: fix: ")
    same_verdicts(mine, out)
    assert p.returncode == 7 and "FAIL  force" in p.stdout


def test_check_on_a_dead_link_fails_the_link_and_skips_the_rest_as_swell_tool_does():
    port = free_udp_port()
    p = subprocess.run([os.path.join(BIN, "swell-tool"), "--link", "udp:%d" % port, "--timeout-ms", "500", "check"],
                       capture_output=True, text=True, timeout=30)
    mine = swell.check("udp:%d" % port, 0.5)
    assert p.returncode == 7 and not mine.ok
    same_verdicts(mine, p.stdout)
    assert str(mine) == p.stdout.rstrip("\n")  # every word: nothing here depends on timing


def test_lost_packets_are_counted_by_sequence_number_across_wraps_of_the_counter():
    from swell import bulk
    sent = np.arange(5000)
    pose = sent // 25  # a coarser clock: one pose every 25 packets
    keep = np.ones(len(sent), bool)
    keep[[10, 11, 700]] = False  # three single losses
    keep[1000:1300] = False  # 300 in a row: more than the 8-bit counter's wrap
    keep[4000:4256] = False  # exactly one wrap: the seq alone shows no gap at all
    seq, clock = sent[keep] % 256, pose[keep]
    assert bulk.lost_by_seq(seq, clock) == 3 + 300 + 256
    assert bulk.lost_by_seq(seq) == 3 + (300 - 256)  # without a clock a wrap is not seen
    assert bulk.lost_by_seq(sent % 256, pose) == 0


def free_tcp_port() -> int:
    import socket
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


@pytest.mark.parametrize("case, hm_more, failed", [
    ("good", [], []),  # swell-ctl on a HapticMaster's interface: the first-run limits, every line ok
    ("uncalibrated", ["--uncalibrated"], ["device", "calibration"]),
    ("e-stop", ["--estop", "0,1000"], ["device", "calibration", "e-stop"]),  # its start-up stops before init
])
def test_check_with_the_hapticmasters_interface_gives_swell_tools_verdicts(tmp_path, case, hm_more, failed):
    """swell-hm serving the HapticMaster's TCP interface, swell-ctl on it (hm:): both checks with --hm."""
    import time
    hm_port, view, clients = free_tcp_port(), free_udp_port(), free_udp_port()
    hm = subprocess.Popen([os.path.join(BIN, "swell-hm"), "--quiet", "--seconds", "60", "--serve",
                           "127.0.0.1:%d" % hm_port] + hm_more, stdout=open(str(tmp_path / "hm.txt"), "w"),
                          stderr=subprocess.STDOUT)
    time.sleep(0.3)
    ctl = subprocess.Popen([os.path.join(BIN, "swell-ctl"), "--device", "hm:127.0.0.1:%d" % hm_port, "--host",
                            "udp:%d,listen=%d" % (view, clients), "--no-rt", "--quiet", "--silent-ticks", "2500",
                            "--seconds", "60"], stdout=open(str(tmp_path / "ctl.txt"), "w"), stderr=subprocess.STDOUT)
    link, spec = "udp:%d" % clients, "127.0.0.1:%d" % hm_port
    try:
        with swell.connect(link, timeout=5.0) as c:
            c.wait_state("armed", 10.0)  # heard, not running (the force law waits for RUN)
            end = time.monotonic() + 5  # dev.rate counts the last whole second: a second after the start-up
            while ("device" not in failed and c.params["dev.rate"] * 2 < c.params["ctl.tick_hz"]
                   and time.monotonic() < end):
                time.sleep(0.2)
            mine, rc, out = agreeing(lambda: (c.check(hm=spec),) + tuple(
                (lambda p: (p.returncode, p.stdout))(subprocess.run(
                    [os.path.join(BIN, "swell-tool"), "--link", link, "--timeout-ms", "2000", "check", "--hm", spec],
                    capture_output=True, text=True, timeout=60))), failed)
    finally:
        for proc in (hm, ctl):
            proc.terminate()
            try:
                proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                proc.kill()
    same_verdicts(mine, out)
    assert [x.name for x in mine.failed] == failed
    assert rc == (7 if failed else 0)
    assert [x.name for x in mine.lines] == ["link", "controller", "device", "round trip", "frame", "force",
                                            "calibration", "e-stop", "effects"]
    if not failed:
        assert mine["force"].text == "force.max 2 N, force.rate 20 N/s (at most 2 N, 20 N/s)"
        assert mine["effects"].text == lines_of_tool(out)[8][2]


def test_a_link_without_its_own_fill_takes_frames_through_recv():
    """CAN and USB fill their rows through recv(): what waits is taken, a long frame is not."""
    from swell import bulk, link

    class Canned(link.Link):
        carrier = "can"

        def __init__(self, frames):
            self.frames = list(frames)

        def recv(self, timeout_s):
            return self.frames.pop(0) if self.frames else None

    src = [("can", 0x210 + k % 16, bytes([k]) * 8) for k in range(10)] + [("can", 0x100, bytes(70))]
    fr = bulk.Frames.empty(8)
    assert Canned(src).fill(fr, 0, 0.0, 0.0) == 8  # only what is waiting, up to the rows there are
    assert [int(x) for x in fr.can_id] == [0x210 + k for k in range(8)]
    assert fr.data[3, :8].tobytes() == bytes([3]) * 8 and list(fr.length) == [8] * 8
    fr = bulk.Frames.empty(20)
    import time
    n = Canned(src).fill(fr, 2, time.monotonic() + 0.2, 0.05)
    assert n == 12 and int(fr.can_id[11]) == 0x219  # the 70-byte frame is dropped
