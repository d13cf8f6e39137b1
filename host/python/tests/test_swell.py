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
        assert isinstance(e, swell.Energy) and e.created_mJ == 0.0 and not e.passivity
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
        with pytest.raises(swell.UnknownParameter, match="unknown parameter 'body.nope'"):
            c.params["body.nope"] = 1
        with pytest.raises(swell.Refused) as e:
            c.params["wave.damping"] = 5  # over the table's 1
        assert e.value.reason == "parameter out of range"
        assert "refused by the controller: parameter out of range" in str(e.value)
        with pytest.raises(swell.Refused, match="not allowed in this state"):
            c.params["body.mass"] = 50  # g: the object floats, its mass is fixed while it displaces water
        with pytest.raises(swell.Refused, match="not allowed in this state"):
            c.params["body.damper"] = 16.5  # likewise
        assert c.params.raw("wave.damping") == before
        assert c.params["body.mass"] == 100
        assert c.params["body.damper"] == 15
        c.params["wave.damping"] = 0.002
        assert c.params["wave.damping"] == pytest.approx(0.002, abs=1e-9)
        c.params.set_raw("wave.damping", before)
        assert c.params.raw("wave.damping") == before


def test_a_dead_link_raises_no_controller_within_its_timeout():
    import time
    t = time.monotonic()
    with pytest.raises(swell.NoController, match="no controller heard"):
        swell.connect("udp:127.0.0.1:%d" % free_udp_port(), timeout=0.5)
    assert time.monotonic() - t < 2.0
    with pytest.raises(swell.LinkError, match="is not one of"):
        swell.connect("tcp:1")


def test_telemetry_into_numpy_and_a_recording_of_it(loop, tmp_path):
    with swell.connect(loop.link) as c:
        with c.stream() as s:
            a = s.to_numpy(seconds=1.0)
            assert s.grid is not None and s.grid.shape == (64, 64)
        assert a.dtype.names == ("t", "seq", "x", "y", "z", "submersion", "fx", "fy", "fz")
        assert len(a) > 50 and s.lost <= len(a) // 1000 + 1
        assert np.all(np.diff(a["t"]) >= 0)
        assert np.all((a["submersion"] >= 0) & (a["submersion"] <= 100))
        n = c.record(str(tmp_path / "t.rec"), 0.5)
    assert n > 20
    carrier, it = read_recording(str(tmp_path / "t.rec"))
    kinds = set()
    for _t, f in it:
        for m in swell.link.decode(f):
            kinds.add(m.name)
    assert {"HEARTBEAT", "OBJECT_POSE", "OBJECT_FORCE"} <= kinds


def test_python_m_swell_speaks_like_swell_tool(loop):
    env = dict(os.environ, PYTHONPATH=os.path.dirname(HERE))
    run = lambda *a: subprocess.run([sys.executable, "-m", "swell", "--link", loop.link] + list(a),
                                    capture_output=True, text=True, env=env, timeout=30)
    p = run("get", "body.damper")
    assert p.returncode == 0 and re.match(r"body.damper = [0-9.]+ N\*s/m", p.stdout), p.stdout + p.stderr
    p = run("get", "body.nope")
    assert p.returncode == 2 and "unknown parameter 'body.nope'" in p.stderr
    p = run("set", "force.max", "1e9")
    assert p.returncode == 6 and "refused by the controller: parameter out of range" in p.stderr
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
        with pytest.raises(swell.Refused, match="the running pool has 64"):
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
            assert np.all(a["fz"][len(a) // 2:] == 0)  # no force while stopped
            c.start()
            c.wait_state("running", 2.0)
    finally:
        lp.stop()
