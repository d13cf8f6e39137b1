"""A live controller and HapticMaster model for the tests: swell-ctl and swell-hm on free loopback
ports (the programs of SWELL_BIN, default build/bin), the model's hand dropping the object."""
import os
import socket
import subprocess
import sys
import time

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
BIN = os.environ.get("SWELL_BIN", os.path.join(HERE, "..", "..", "..", "build", "bin"))


def free_udp_port() -> int:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


class Loop:
    """The controller faults after 250 silent ticks (100 ms), not the real-time 2: a loaded machine
    (a CI run on 2 cores) delays a process without real-time scheduling by milliseconds."""

    def __init__(self, tmp, hand="drop:z=20,hold=0.5", seconds=60):
        self.dev, self.view, self.clients = free_udp_port(), free_udp_port(), free_udp_port()
        self.link = "udp:127.0.0.1:%d" % self.clients
        self.ctl = subprocess.Popen([os.path.join(BIN, "swell-ctl"), "--autorun", "--quiet", "--no-rt",
                                     "--silent-ticks", "250", "--device", "udp:%d" % self.dev,
                                     "--host", "udp:%d,listen=127.0.0.1:%d" % (self.view, self.clients)],
                                    stdout=open(os.path.join(tmp, "ctl.txt"), "w"), stderr=subprocess.STDOUT)
        time.sleep(0.3)
        self.hm = subprocess.Popen([os.path.join(BIN, "swell-hm"), "--quiet", "--watchdog", "25", "--port",
                                    str(self.dev), "--hand", hand, "--seconds", str(seconds)],
                                   stdout=open(os.path.join(tmp, "hm.txt"), "w"), stderr=subprocess.STDOUT)

    def tool(self, *args):
        """swell-tool on the same controller: (exit status, output)."""
        p = subprocess.run([os.path.join(BIN, "swell-tool"), "--link", "udp:%d" % self.clients] + list(args),
                           capture_output=True, text=True, timeout=30)
        return p.returncode, p.stdout + p.stderr

    def stop(self):
        for p in (self.hm, self.ctl):
            p.terminate()
            try:
                p.wait(timeout=5)
            except subprocess.TimeoutExpired:
                p.kill()


    def wait_floating(self, timeout=15.0):
        """Until the dropped object is in the water (its mass and size are then fixed)."""
        import swell
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            try:
                with swell.connect(self.link, timeout=1.0) as c, c.stream() as s:
                    if s.to_numpy(seconds=0.3)["submersion"].min() > 50:
                        return
            except swell.SwellError:
                time.sleep(0.2)
        raise RuntimeError("the object is not in the water after %.0f s" % timeout)


@pytest.fixture(scope="module")
def loop(tmp_path_factory):
    lp = Loop(str(tmp_path_factory.mktemp("loop")))
    lp.wait_floating()
    yield lp
    lp.stop()
