"""A trial as a lab scripts it: the object is dropped into the pool (the HapticMaster model's hand
lets go of it), 5 s of telemetry are recorded into numpy, force and depth are plotted to a PNG, and the
rest depth is checked against the floating equilibrium m g = rho g a b delta, corrected for the water
level the object raises (it displaces a b delta over the pool's area).

    tools/py host/python/examples/drop_and_plot.py --link udp:127.0.0.1:47802 --out drop.png

Exit status: 0 the object rests within 0.5 % of the level-corrected depth, 1 it does not, 3 no controller."""
import argparse
import sys

import swell

RHO = 1000.0  # kg/m^3, water


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--link", default="udp:127.0.0.1:47802")
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--out", default="drop.png", help="the PNG to write")
    a = ap.parse_args()
    try:
        c = swell.connect(a.link)
    except swell.SwellError as e:
        print("drop_and_plot: %s" % e, file=sys.stderr)
        return 3
    with c:
        info = c.info
        m_kg = c.params["body.mass"] / 1000.0
        a_m, b_m = c.params["body.a"] / 1000.0, c.params["body.b"] / 1000.0
        with c.stream() as s:
            t = s.to_numpy(seconds=a.seconds)
    delta_m = m_kg / (RHO * a_m * b_m)
    pool_m2 = (info.grid[0] * info.dx_mm / 1000.0) * (info.grid[1] * info.dx_mm / 1000.0)
    expect_mm = (-delta_m + a_m * b_m * delta_m / pool_m2) * 1000.0
    if not len(t):
        print("drop_and_plot: no samples in %.1f s" % a.seconds, file=sys.stderr)
        return 1
    last = t[t["t"] >= t["t"][-1] - 1.0]
    rest_mm = float(last["z"].mean())
    err = abs(rest_mm - expect_mm) / abs(expect_mm)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
    ax1.plot(t["t"], t["fz"], lw=1)
    ax1.set_ylabel("force z (N)")
    ax1.set_title("swell: the object dropped, %d samples, %d lost" % (len(t), t.lost_samples))
    ax2.plot(t["t"], t["z"], lw=1, label="bottom of the object")
    ax2.axhline(expect_mm, color="k", ls="--", lw=0.8, label="level-corrected rest %.3f mm" % expect_mm)
    ax2.set_ylabel("z (mm)")
    ax2.set_xlabel("time (s)")
    ax2.legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(a.out, dpi=90)
    print("rest depth %.3f mm over the last second, expected %.3f mm (%.3f %% off); %d samples, %d lost; "
          "%d packets, %d lost; plot %s" % (rest_mm, expect_mm, 100 * err, len(t), t.lost_samples, t.packets,
                                            t.lost_packets, a.out))
    return 0 if err <= 0.005 else 1


if __name__ == "__main__":
    sys.exit(main())
