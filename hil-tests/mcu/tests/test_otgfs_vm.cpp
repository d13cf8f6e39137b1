// The USB tunnel end to end: the HIL VM (hil-tests/vm/run-vm --usb-tunnel, on its default
// virtio-serial line) imports the OTG FS model through swell-vm-usbip-bridge and vhci-hcd, and the
// VM's Linux enumerates it and runs swell-vm-usbtest (libusb) against it. This process is the USB/IP server (usbip.c) with the model
// driven by the scripted driver of otgfs_script.hpp, standing where swell-mcu runs the image.
// Environment: SWELL_RUN_VM (the run-vm script), SWELL_VM_IMAGE (build-image's output),
// SWELL_VM_BIN (the programs for the VM); the test is skipped (exit 77) without them.
#include <catch2/catch.hpp>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <ctime>
#include <memory>
#include <string>

#include "otgfs_script.hpp"

extern "C" {
#include "usbip.h"
}

using namespace otgfs_script;

namespace
{

struct Env {
	const char *run_vm = std::getenv("SWELL_RUN_VM");
	const char *image = std::getenv("SWELL_VM_IMAGE");
	const char *bin = std::getenv("SWELL_VM_BIN");
	bool ok() const
	{
		return run_vm && image && bin;
	}
};

// Listen on a fresh Unix socket path; returns the listening fd.
int listen_unix(const std::string &path)
{
	int fd = socket(AF_UNIX, SOCK_STREAM, 0);
	REQUIRE(fd >= 0);
	sockaddr_un a{};
	a.sun_family = AF_UNIX;
	REQUIRE(path.size() < sizeof(a.sun_path));
	std::memcpy(a.sun_path, path.c_str(), path.size() + 1);
	REQUIRE(bind(fd, (sockaddr *)&a, sizeof(a)) == 0);
	REQUIRE(listen(fd, 1) == 0);
	return fd;
}

struct Run {
	int status = -1;
	uint32_t submits = 0, errors = 0, faults = 0, sessions = 0;
	std::string server_error;
	bool unplugged = false, replugged = false;
};

double wall_s()
{
	timespec ts{};
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

// Start run-vm with the commands, serve the tunnel until it exits. unplug_after > 0: once that
// many bulk IN packets went out, the driver takes its pull-up off (DCTL.SDIS) for 3 s, which ends
// the session; the next connection (QEMU dials again) imports the device anew.
Run run_vm_with(const Env &env, const std::string &commands, unsigned unplug_after = 0)
{
	Run out;
	const char *tmp = std::getenv("TMPDIR");
	std::string tmpl = std::string(tmp && *tmp ? tmp : "/tmp") + "/swell-usbip.XXXXXX";
	std::vector<char> dir(tmpl.begin(), tmpl.end());
	dir.push_back('\0');
	REQUIRE(mkdtemp(dir.data()) != nullptr);
	std::string sock = std::string(dir.data()) + "/usb.sock";
	int lfd = listen_unix(sock);
	pid_t pid = fork();
	REQUIRE(pid >= 0);
	if (pid == 0) {
		execl(env.run_vm, env.run_vm, "--image", env.image, "--bin", env.bin, "--can", "none", "--usb", "none",
		      "--usb-tunnel", sock.c_str(), "--timeout", "280", "--", commands.c_str(), (char *)nullptr);
		_exit(125);
	}
	std::unique_ptr<otgfs> m(new otgfs);
	std::unique_ptr<usbip_server> srv(new usbip_server);
	uint64_t now = 0;
	otgfs_init(m.get(), 1000000000u);
	Driver drv(m.get(), &now);
	REQUIRE(drv.start());
	int cfd = -1;
	double t_done = 0, t_unplug = 0;
	auto tally = [&] {
		out.submits += srv->stats.submits;
		out.errors += srv->stats.errors;
		if (srv->error)
			out.server_error = srv->error;
	};
	for (;;) {
		if (waitpid(pid, &out.status, WNOHANG) == pid)
			break;
		if (unplug_after && !out.unplugged) {
			if (!t_done && drv.bulk_ins >= unplug_after)
				t_done = wall_s();
			if (t_done && wall_s() > t_done + 0.5) {
				drv.wr(DCTL, drv.rd(DCTL) | 2u); // SDIS: the pull-up off
				out.unplugged = true;
				t_unplug = wall_s();
			}
		}
		if (out.unplugged && !out.replugged && wall_s() > t_unplug + 3.0) {
			drv.wr(DCTL, drv.rd(DCTL) & ~2u);
			out.replugged = true;
		}
		if (cfd < 0) {
			pollfd p{ lfd, POLLIN, 0 };
			if (poll(&p, 1, 50) == 1) {
				cfd = accept(lfd, nullptr, nullptr);
				if (cfd >= 0) {
					usbip_server_init(srv.get(), cfd, m.get(), 3);
					out.sessions++;
				}
			}
			drv.isr();
			now += 50000;
			otgfs_advance(m.get(), now);
			continue;
		}
		enum usbip_step st = usbip_server_step(srv.get(), now);
		drv.isr();
		now += 20000; // 20 us of the device's time per turn
		otgfs_advance(m.get(), now);
		if (st == USBIP_CLOSED) { // the VM let go, or the device left the bus: wait for the next dial
			tally();
			close(cfd);
			cfd = -1;
			continue;
		}
		if (st == USBIP_IDLE) {
			pollfd p{ cfd, POLLIN, 0 };
			(void)poll(&p, 1, 5);
		}
	}
	if (cfd >= 0) {
		tally();
		close(cfd);
	}
	close(lfd);
	unlink(sock.c_str());
	rmdir(dir.data());
	out.faults = otgfs_fault_count(m.get());
	return out;
}

} // namespace

TEST_CASE("USB tunnel: the VM's Linux enumerates the OTG FS model over USB/IP and libusb echoes 300 packets through it")
{
	Env env;
	if (!env.ok()) {
		WARN("SWELL_RUN_VM, SWELL_VM_IMAGE or SWELL_VM_BIN not set: skipped");
		std::exit(77);
	}
	Run r = run_vm_with(env,
			    "swell-vm-usbtest --count 300 --lengths vary --expect-ep-in 0x81 --expect-ep-out 0x01");
	INFO("server: " << r.server_error);
	REQUIRE(WIFEXITED(r.status));
	CHECK(WEXITSTATUS(r.status) == 0);
	CHECK(r.submits >= 600); // 300 OUT and 300 IN URBs at least
	CHECK(r.faults == 0u);
}

TEST_CASE("USB tunnel: an unplug (the pull-up off) takes the device off the VM's bus and the replug brings it back to "
	  "libusb")
{
	Env env;
	if (!env.ok()) {
		WARN("SWELL_RUN_VM, SWELL_VM_IMAGE or SWELL_VM_BIN not set: skipped");
		std::exit(77);
	}
	// The VM: 100 packets, then the device must vanish from vhci-hcd and come back configured, and
	// 100 packets again.
	const std::string dev = "/sys/devices/platform/vhci_hcd.0/usb*/[0-9]*-[0-9]*/bConfigurationValue";
	const std::string cmds = "swell-vm-usbtest --count 100 --lengths vary && "
				 "n=0; while cat " +
		dev +
		" >/dev/null 2>&1; do [ $n -lt 300 ] || exit 11; sleep 0.1; "
		"n=$((n+1)); done; echo unplugged after $n && "
		"n=0; until cat " +
		dev +
		" 2>/dev/null | grep -q '^[1-9]'; do [ $n -lt 600 ] || exit 12; "
		"sleep 0.1; n=$((n+1)); done; echo back after $n && "
		"swell-vm-usbtest --count 100 --lengths vary";
	Run r = run_vm_with(env, cmds, 100);
	INFO("server: " << r.server_error);
	REQUIRE(WIFEXITED(r.status));
	CHECK(WEXITSTATUS(r.status) == 0);
	CHECK(r.unplugged);
	CHECK(r.replugged);
	CHECK(r.sessions == 2u);
	CHECK(r.faults == 0u);
}
