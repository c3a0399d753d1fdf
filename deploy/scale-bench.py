#!/usr/bin/env python3
"""Table, plot and model of deploy/scale-bench.sh's runs (scale.csv): prints markdown, writes a PNG.

The model is extrapolated from the measured costs, not measured. Per frame:
  clients   t_c(N) = (f_c + W·H·e_px + S·p_set + N·o_c) / (N · host_cores)
            f_c, e_px : client CPU seconds per frame and per pixel (walkthrough: no photons shot;
                    told apart by the calibration run at twice the width and height)
            p_set : client CPU seconds per interleaving set for shooting and inserting P paths
                    ((interaction − walkthrough) / sets, at the same client count)
            o_c   : client CPU seconds per client and frame that do not shrink with more clients
                    (slope of a least-squares line of client CPU against N)
            S     : sets; S = M² must be ≥ N or the extra clients idle as spares (M = 8 for 64)
  client link   t_l(N) = (B / N) · 8 / 100 Mbit/s
  master CPU    t_m(N) = f_m + W·H·e_m + N·o_m (one core: decode, assembly, filter, compose)
  master link   t_n    = B · 8 / L,  B = W·H · bytes per pixel (measured with the default encoding)
  fps(N) = 1 / max(t_c, t_l, t_m, t_n): frames are pipelined, so the slowest stage sets the rate.
"""
import argparse
import csv
import math
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402


def fnum(v):
    try:
        x = float(v)
        return x if math.isfinite(x) else None
    except (TypeError, ValueError):
        return None


def linfit(xs, ys):
    """Least-squares line y = a + b·x; (a, b). One point: (y, 0)."""
    n = len(xs)
    if n == 1:
        return ys[0], 0.0
    mx, my = sum(xs) / n, sum(ys) / n
    sxx = sum((x - mx) ** 2 for x in xs)
    b = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx if sxx > 0 else 0.0
    return my - b * mx, b


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--csv", required=True)
    ap.add_argument("--png", required=True)
    ap.add_argument("--machine", default="")
    ap.add_argument("--command", default="")
    ap.add_argument("--model-width", type=int, default=640)
    ap.add_argument("--model-height", type=int, default=480)
    ap.add_argument("--model-m", type=int, default=8)
    ap.add_argument("--model-host-cores", type=float, default=2.0)
    args = ap.parse_args()

    allcsv = list(csv.DictReader(open(args.csv)))
    if not allcsv:
        sys.exit("scale-bench.py: no rows in " + args.csv)
    base_px = int(allcsv[0]["width"]) * int(allcsv[0]["height"])
    rows = [r for r in allcsv if int(r["width"]) * int(r["height"]) == base_px]
    calib = [r for r in allcsv if int(r["width"]) * int(r["height"]) != base_px]
    by = defaultdict(dict)
    for r in rows:
        by[r["mode"]][int(r["clients"])] = r
    modes = [m for m in ("interaction", "walkthrough") if m in by]
    r0 = rows[0]
    w, h, m = int(r0["width"]), int(r0["height"]), int(r0["M"])
    sets = m * m
    qc, qm = float(r0["client_cores"]), float(r0["master_cores"])

    out = []
    p = out.append
    p("### Scaling by client count on emulated hosts (paper Table 6 shape)")
    p("")
    p(f"Command: `{args.command}`  ")
    p(f"Machine: {args.machine}  ")
    p(f"{r0['scene']} at {w}×{h}, M = {m} ({sets} sets), default wire encoding. Every client is a network "
      f"namespace on a 100 Mbit/s tbf-shaped link with a CPU quota of {qc:g} core (cgroup v1 "
      f"cpu.cfs_quota_us) and one render thread; the master has its own namespace on a 1 Gbit/s "
      f"uplink and {qm:g} core. Interaction: {by['interaction'][min(by['interaction'])]['frames'] if 'interaction' in by else '?'} "
      f"frames of P = 20 000 paths per set; walkthrough: the first frame shoots, the others only trace.")
    p("fps is the master's rate over the frames after frame 0, on a machine shared with other work "
      "(load = 1-minute load average at the start of each run), so it falls short of what the quotas allow; "
      "*fps at quota* = 1 / max(client CPU / (N·quota), master CPU / quota) is the rate the measured CPU "
      "seconds allow on dedicated cores. CPU seconds per frame (cgroup cpuacct, after frame 0) do not "
      "depend on the load. Bytes per frame: pixel payload the master received; link bytes: what the "
      "clients' shaped interfaces sent (payload + headers + TCP). Error: relative RMSE of the filtered "
      "caustic against a converged reference (rtpm-compare); the cluster's image does not depend on N.")
    p("")
    p("| mode | clients | fps | fps / fps(1) | fps at quota | client CPU s/frame | master CPU s/frame "
      "| bytes/frame | link bytes/frame | photons (all sets) | caustic rel. RMSE | incomplete | load |")
    p("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for mode in modes:
        base = None
        for n in sorted(by[mode]):
            r = by[mode][n]
            fps, cc, mc = fnum(r["fps"]), fnum(r["client_cpu_s_per_frame"]), fnum(r["master_cpu_s_per_frame"])
            base = base or fps
            # A quota rate needs both CPU figures; cpuacct reads 0 for a master that did next to nothing.
            quota_fps = f"{1.0 / max(cc / (n * qc), mc / qm):.2f}" if cc and mc else "n/a"
            p(f"| {mode} | {n} | {fps:.2f} | {fps / base:.2f} | "
              f"{quota_fps} | {cc:.3f} | {mc:.4f} | {float(r['bytes_per_frame']) / 1e3:.0f} kB | "
              f"{float(r['client_link_bytes_per_frame']) / 1e3:.0f} kB | {float(r['photons_total']):.0f} | "
              f"{fnum(r['caustic_rel_rmse']):.3f} | {r['incomplete']} | {r['load1']} |")
    p("")

    # ---- model inputs -------------------------------------------------------------------------
    pix = w * h
    walk = by.get("walkthrough", {})
    inter = by.get("interaction", {})
    cpu = lambda r, who: float(r[who + "_cpu_s_per_frame"])  # noqa: E731
    # Per-client slopes: least-squares lines of CPU per frame against N, over both modes.
    ns_w, ns_i = sorted(walk), sorted(inter)
    _, o_c_w = linfit(ns_w, [cpu(walk[n], "client") for n in ns_w]) if ns_w else (0, 0)
    _, o_c_i = linfit(ns_i, [cpu(inter[n], "client") for n in ns_i]) if ns_i else (0, 0)
    o_c = max((o_c_w + o_c_i) / 2, 0.0)
    allrows = [r for mode in modes for r in by[mode].values()]
    _, o_m = linfit([int(r["clients"]) for r in allrows], [cpu(r, "master") for r in allrows])
    o_m = max(o_m, 0.0)
    # Photon shooting per set: interaction minus walkthrough at the same N (walkthrough shoots none).
    common = sorted(set(ns_w) & set(ns_i))
    p_set = max(sum(cpu(inter[n], "client") - cpu(walk[n], "client") for n in common) / len(common) / sets, 0.0) \
        if common else 0.0
    # Fixed and per-pixel parts from the calibration run (walkthrough, largest N, 2× width and height).
    nmax = max(ns_w) if ns_w else 0
    cal = next((r for r in calib if r["mode"] == "walkthrough" and int(r["clients"]) == nmax), None)
    if cal is not None and nmax in walk:
        dpx = int(cal["width"]) * int(cal["height"]) - pix
        e_px = max((cpu(cal, "client") - cpu(walk[nmax], "client")) / dpx, 0.0)
        e_m = max((cpu(cal, "master") - cpu(walk[nmax], "master")) / dpx, 0.0)
        f_c = max(cpu(walk[nmax], "client") - e_px * pix - o_c * nmax, 0.0)
        f_m = max(cpu(walk[nmax], "master") - e_m * pix - o_m * nmax, 0.0)
        calib_note = (f"calibration: walkthrough with {nmax} clients at {cal['width']}×{cal['height']} "
                      f"(client CPU {cpu(cal, 'client'):.3f} s, master {cpu(cal, 'master'):.4f} s per frame)")
    else:
        e_px = max(cpu(walk[nmax], "client") if nmax else 0.0, 0.0) / pix
        e_m = max(cpu(walk[nmax], "master") if nmax else 0.0, 0.0) / pix
        f_c = f_m = 0.0
        calib_note = "no calibration run: every cost taken as per pixel (overestimates larger images)"
    bpp = sum(float(r["bytes_per_frame"]) for r in allrows) / len(allrows) / pix

    W, H, M = args.model_width, args.model_height, args.model_m
    S, hc = M * M, args.model_host_cores
    links = [1e9, 10e9, 25e9]

    def stages(n, link):
        B = W * H * bpp
        t = {"client CPU": (f_c + W * H * e_px + S * p_set + n * o_c) / (n * hc),
             "client link": B / n * 8 / 100e6,
             "master CPU": f_m + W * H * e_m + n * o_m,
             "master link": B * 8 / link}
        return t

    def fps_of(n, link):
        t = stages(n, link)
        k = max(t, key=t.get)
        return 1.0 / t[k], k

    p("### MODEL — extrapolated from the runs above, not measured")
    p("")
    p("Inputs fitted from the table and the " + calib_note + ": "
      f"clients f_c = {f_c * 1e3:.1f} CPU ms per frame + e_px = {e_px * 1e9:.0f} CPU ns per pixel "
      f"+ p_set = {p_set * 1e3:.2f} CPU ms per set for P = 20 000 paths + o_c = {o_c * 1e3:.2f} CPU ms per client; "
      f"master f_m = {f_m * 1e3:.2f} CPU ms per frame + e_m = {e_m * 1e9:.1f} CPU ns per pixel "
      f"+ o_m = {o_m * 1e6:.0f} CPU µs per client; {bpp:.2f} bytes per pixel on the wire.")
    p(f"Model cluster: {W}×{H} (the paper's size), M = {M} ({S} sets, so up to {S} clients own sets), "
      f"interaction mode, every client host {hc:g} cores of this machine with perfect scaling inside a host, "
      "100 Mbit/s per client, master CPU work on one core, master link 1, 10 or 25 Gbit/s. "
      "fps = 1 / max(stage times): frames are pipelined. See the docstring of deploy/scale-bench.py.")
    p("")
    p("| clients | fps @ 1 Gbit/s | fps @ 10 Gbit/s | fps @ 25 Gbit/s | limited by (1 / 10 / 25 Gbit/s) |")
    p("|---|---|---|---|---|")
    model_ns = [1, 2, 4, 8, 16, 32, 64]
    for n in model_ns:
        cells = [fps_of(n, L) for L in links]
        p(f"| {n} | " + " | ".join(f"{f:.1f}" for f, _ in cells) + " | " + " / ".join(k for _, k in cells) + " |")
    p("")
    for L in links:
        sat = None
        for n in range(1, S + 1):
            _, k = fps_of(n, L)
            if k.startswith("master"):
                sat = (n, k)
                break
        if sat:
            tm = stages(sat[0], L)
            p(f"- {L / 1e9:g} Gbit/s master link: the master saturates from about {sat[0]} clients on, bound by "
              f"its {sat[1].split()[1]} ({1 / max(tm['master CPU'], tm['master link']):.1f} fps ceiling there: "
              f"master CPU {tm['master CPU'] * 1e3:.1f} ms, link {tm['master link'] * 1e3:.1f} ms per frame; "
              f"the master's CPU grows by {o_m * 1e6:.0f} µs per client).")
        else:
            tm = stages(S, L)
            f64, k64 = fps_of(S, L)
            p(f"- {L / 1e9:g} Gbit/s master link: the clients stay the bottleneck up to {S} clients "
              f"({f64:.1f} fps at {S}, bound by {k64}); master CPU {tm['master CPU'] * 1e3:.1f} ms and link "
              f"{tm['master link'] * 1e3:.1f} ms per frame leave room.")
    f32 = W * H * 24 * 8
    p(f"- With `--encoding float32` (24 bytes/pixel by the protocol, not measured here) a frame is "
      f"{W * H * 24 / 1e6:.1f} MB: {1e9 / f32:.1f} fps at most through 1 Gbit/s, {10e9 / f32:.0f} through "
      f"10 Gbit/s, {25e9 / f32:.0f} through 25 Gbit/s.")
    p("")

    # ---- plot ----------------------------------------------------------------------------------
    fig, ax = plt.subplots(2, 3, figsize=(15, 8.5))
    colors = {"interaction": "tab:blue", "walkthrough": "tab:orange"}
    for mode in modes:
        ns = sorted(by[mode])
        c = colors[mode]
        get = lambda key: [float(by[mode][n][key]) for n in ns]  # noqa: E731
        fps = get("fps")
        cc, mc = get("client_cpu_s_per_frame"), get("master_cpu_s_per_frame")
        ax[0][0].plot(ns, fps, "o-", color=c, label=f"{mode} (measured, loaded machine)")
        ax[0][0].plot(ns, [1.0 / max(a / (n * qc), b / qm) if a and b else math.nan for n, a, b in zip(ns, cc, mc)],
                      "s:", color=c,
                      label=f"{mode} at quota (from CPU s)")
        ax[0][1].plot(ns, cc, "o-", color=c, label=f"{mode} clients")
        ax[0][1].plot(ns, mc, "^--", color=c, label=f"{mode} master")
        ax[0][2].plot(ns, [b / 1e3 for b in get("bytes_per_frame")], "o-", color=c, label=f"{mode} payload")
        ax[0][2].plot(ns, [b / 1e3 for b in get("client_link_bytes_per_frame")], "^--", color=c,
                      label=f"{mode} client links")
        err = [fnum(by[mode][n]["caustic_rel_rmse"]) for n in ns]
        ax[1][0].plot([n for n, e in zip(ns, err) if e is not None], [e for e in err if e is not None], "o-",
                      color=c, label=mode)
    ax[0][0].set_title(f"fps vs clients ({w}×{h}, M = {m}, {qc:g} core per client)")
    ax[0][1].set_title("CPU seconds per frame")
    ax[0][2].set_title("bytes per frame (kB)")
    ax[1][0].set_title("caustic rel. RMSE vs converged reference")
    for a in (ax[0][0], ax[0][1], ax[0][2], ax[1][0]):
        a.set_xscale("log", base=2)
        a.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        a.set_xlabel("clients")
        a.legend(fontsize=7)
        a.grid(alpha=0.3)
    mn = list(range(1, S + 1))
    for L, style in zip(links, ["-", "--", ":"]):
        ax[1][1].plot(mn, [fps_of(n, L)[0] for n in mn], style, label=f"master link {L / 1e9:g} Gbit/s")
    ax[1][1].set_title(f"MODEL (not measured): {W}×{H}, M = {M}, {hc:g}-core hosts")
    ax[1][1].set_xscale("log", base=2)
    ax[1][1].xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    ax[1][1].set_xlabel("clients")
    ax[1][1].set_ylabel("fps")
    ax[1][1].legend(fontsize=7)
    ax[1][1].grid(alpha=0.3)
    for n in (16, 64):
        st = stages(n, 1e9)
        ax[1][2].bar([f"{k}\n{n} cl." for k in st], [v * 1e3 for v in st.values()], alpha=0.7)
    ax[1][2].set_title("MODEL stage times per frame at 1 Gbit/s (ms)")
    ax[1][2].tick_params(axis="x", labelsize=6)
    fig.suptitle("rtpm scaling on emulated hosts (measured) and a model beyond them", fontsize=12)
    fig.tight_layout()
    fig.savefig(args.png, dpi=110)
    print("\n".join(out))


if __name__ == "__main__":
    main()
