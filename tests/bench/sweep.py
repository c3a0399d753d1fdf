#!/usr/bin/python3
"""Speed-against-error sweep of rtpm-render (and the local cluster) on RING, GLASS and HEADLIGHT.

Usage (build rtpm-render, rtpm-compare, rtpm-server and rtpm-client first; tests/bench/sweep.sh
does that):
  sweep.py --build BUILD --make-references   converged references into BUILD/sweep-cache (once)
  sweep.py --build BUILD --run               the sweep -> tests/bench/sweep_results.csv + report
  sweep.py --report                          SWEEP.md and sweep_<scene>.png from the CSV only
Options for a small run elsewhere (the bench-smoke test): --out DIR (the CSV, SWEEP.md, PNGs and
JSON notes; default tests/bench), --cache DIR (references and images; default BUILD/sweep-cache),
--size WxH (default 320x240), --ref-photons P (paths per set of each reference frame).

Every sweep point is one process run from reset. Its time per frame is the median total_ms of
the frames in the mode it measures (interaction: frame 0 only; accumulation: frames 1..N-1;
walkthrough: frames after the cap), its error is the relative RMSE of the last frame's
caustic_filtered layer over the caustic region of the reference (rtpm-compare), and its time to
the image is the sum of all frames' total_ms. Grid: one factor at a time around the paper's
operating point (3x3 interleave, P = 8000, k = 64, F = 3, SPT) plus a P x frames x k grid.
"""
import argparse
import csv
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
BENCH = ROOT / "tests" / "bench"
RESULTS_CSV = BENCH / "sweep_results.csv"
SWEEP_MD = BENCH / "SWEEP.md"
SCENES = ["RING", "GLASS", "HEADLIGHT"]
WIDTH, HEIGHT = 320, 240
TARGET_ERROR = 0.02  # "2 % error": relative RMSE of caustic_filtered over the caustic region
TARGET_MS = 100.0  # 10 fps

# Converged references: M = 3, F = 3 like the sweep's base (the box filter's blur is part of the
# method's limit), no cap, and a photon density ~4x the densest sweep point (N = 32000 x 8 frames
# = 256k photons per set) so that the k-NN radius, sqrt(k / density), is well below every sweep
# point's: the kNN blur of a reference with too few photons is itself an error the sweep would
# "measure" as its points get sharper. k = 400 balances that blur against the reference's noise
# (~1/sqrt(9 k) per pixel). Two seeds are rendered and averaged; their difference measures the
# noise left (the error floor). HEADLIGHT's paths cost ~10x RING's (a deep reflector) but ~60 %
# of them store a photon, so it needs far fewer.
REFERENCES = {
    "RING": dict(P=8_000_000, frames=3, k=400),
    "GLASS": dict(P=8_000_000, frames=3, k=400),
    "HEADLIGHT": dict(P=500_000, frames=3, k=400),
}
REF_SEEDS = [1, 2]

# Base point: the paper's operating point (3x3 sets, N = 8000-16000 stored photons per set and
# frame, k = 40-100); P (paths per set) is derived from N and the scene's yield.
BASE = dict(N=8000, P=0, k=64, M=3, F=3, spt=1, tree="", frames=1, clients=0, cap=0)

FIELDS = ["scene", "group", "label", "paper", "N", "P", "k", "M", "F", "spt", "tree", "frames", "clients",
          "cap", "width", "height", "mode", "ms_per_frame", "fps", "cum_ms", "cpu_ms_per_frame",
          "photons_per_set", "rel_rmse", "rel_mae", "energy", "image_rel_rmse", "load1", "image"]


def log(msg):
    print(msg, file=sys.stderr, flush=True)


class Tools:
    def __init__(self, build, cache=None):
        self.build = Path(build).resolve()
        self.render = self.build / "common" / "cmd" / "rtpm-render"
        self.compare = self.build / "common" / "cmd" / "rtpm-compare"
        self.server = self.build / "server" / "rtpm-server"
        self.client = self.build / "client" / "rtpm-client"
        self.cache = Path(cache).resolve() if cache else self.build / "sweep-cache"
        for exe in (self.render, self.compare):
            if not exe.is_file():
                sys.exit(f"sweep.py: {exe} is not built (tests/bench/sweep.sh builds it)")
        self.cache.mkdir(parents=True, exist_ok=True)
        help_text = subprocess.run([str(self.render), "--help"], capture_output=True, text=True).stdout
        self.has_tree = "--tree" in help_text
        self.tree_help = next((l.strip() for l in help_text.splitlines() if "--tree" in l), "")

    def ref_path(self, scene):
        return self.cache / f"ref_{scene.lower()}_{WIDTH}x{HEIGHT}.exr"


def run_timed(cmd, cwd=None):
    """Runs cmd to completion; returns (returncode, stdout, stderr). Its CPU time shows up in
    children_cpu() once it is reaped."""
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=cwd)
    return r.returncode, r.stdout, r.stderr


def children_cpu():
    r = os.times()
    return r.children_user + r.children_system


def render_args(scene, pt, out, csv_path, seed=None):
    a = [f"--scene={scene}", f"--width={WIDTH}", f"--height={HEIGHT}", f"--frames={pt['frames']}",
         f"--photons={pt['P']}", f"--k={pt['k']}", f"--interleave={pt['M']}", f"--filter={pt['F']}", f"--cap={pt['cap']}",
         f"--out={out}", f"--csv={csv_path}"]
    if not pt["spt"]:
        a.append("--no-spt")
    if pt.get("tree"):
        a.append(f"--tree={pt['tree']}")
    if seed is not None:
        a.append(f"--seed={seed}")
    return a


def compare(tools, out, ref):
    r = subprocess.run([str(tools.compare), str(out), str(ref), "--layer", "caustic_filtered", "--csv"],
                       capture_output=True, text=True)
    if r.returncode not in (0, 2):
        raise RuntimeError(f"rtpm-compare failed: {r.stderr.strip()}")
    row = next(csv.DictReader(r.stdout.splitlines()))
    return {"rel_rmse": float(row["caustic_rel_rmse"]), "rel_mae": float(row["caustic_rel_mae"]),
            "energy": float(row["energy_ratio"]), "image_rel_rmse": float(row["image_rel_rmse"])}


def make_references(tools, scenes, ref_photons=None):
    meta_path = tools.cache / "references.json"
    meta = json.loads(meta_path.read_text()) if meta_path.exists() else {}
    if not shutil.which("oiiotool"):
        sys.exit("sweep.py: oiiotool (openimageio-tools) is needed to average the two reference seeds")
    for scene in scenes:
        r = dict(REFERENCES[scene], **({"P": ref_photons} if ref_photons else {}))
        pt = dict(BASE, P=r["P"], frames=r["frames"], k=r["k"], cap=0)
        parts = []
        t0 = time.time()
        for seed in REF_SEEDS:
            out = tools.cache / f"ref_{scene.lower()}_seed{seed}.exr"
            csv_path = tools.cache / f"ref_{scene.lower()}_seed{seed}.csv"
            done = out.exists() and csv_path.exists() and len(list(csv.DictReader(open(csv_path)))) == r["frames"]
            if done:
                log(f"reference {scene} seed {seed}: kept {out.name} (delete it to render again)")
            else:
                csv_path.unlink(missing_ok=True)
                log(f"reference {scene} seed {seed}: P={r['P']} x {r['frames']} frames, k={r['k']}")
                rc, so, se = run_timed([str(tools.render)] + render_args(scene, pt, out, csv_path, seed))
                if rc != 0:
                    sys.exit(f"sweep.py: reference render failed: {se.strip()}")
            rows = list(csv.DictReader(open(csv_path)))
            parts.append((out, int(rows[-1]["photons"]), int(rows[-1]["paths"])))
        # The two seeds' difference: rel RMSE(A - B) = sqrt(2) sigma of one, sigma of the mean = that / 2.
        diff = compare(tools, parts[0][0], parts[1][0])
        ref = tools.ref_path(scene)
        subprocess.run(["oiiotool", str(parts[0][0]), str(parts[1][0]), "--add", "--mulc", "0.5", "-o", str(ref)],
                       check=True)
        meta[scene] = dict(settings=dict(r, M=3, F=3, width=WIDTH, height=HEIGHT, seeds=REF_SEEDS),
                           photons_total=sum(p[1] for p in parts), paths_total=sum(p[2] for p in parts),
                           seed_diff_rel_rmse=diff["rel_rmse"], floor_rel_rmse=diff["rel_rmse"] / 2,
                           seed_energy_ratio=diff["energy"], wall_s=round(time.time() - t0, 1))
        log(f"reference {scene}: {meta[scene]}")
        meta_path.write_text(json.dumps(meta, indent=1))


# ---------------------------------------------------------------------------------------- grid

def sweep_points(scene, tools, quick=False):
    """(group, label, point) in run order: one factor at a time around BASE plus a grid.

    The paper counts *stored* photons per set (Fig. 4: 8000-16000 per client; Table 6: RING 81k
    photons in interaction = 9k per set), while rtpm's P counts light *paths* per set. So the
    points name a target N of stored photons per set per frame, and P = N / yield, with the
    scene's frame-0 yield measured by the first point (rtpm's defaults, P = 20000 paths). A point
    with "P" in place of N is "nat" (P paths, whatever they store)."""
    heavy = scene == "HEADLIGHT"  # ~10x the cost per photon path: a thinner grid
    pts = []

    def add(group, label, **kw):
        pts.append((group, label, dict(BASE, **kw)))

    add("default", "rtpm defaults (P=20000 paths, k=64)", P=20000, N=0)
    add("base", "base: paper point N=8000 k=64")
    for N in [1000, 2000, 4000, 16000, 32000]:
        add("N", f"N={N}", N=N)
    for k in [10, 20, 40, 100, 200, 400]:
        add("k", f"k={k}", k=k)
    for F in [1, 2, 5, 7]:
        add("F", f"F={F}", F=F)
    # Interleave at a constant photon budget per frame (M^2 N = 72000 photons): more sets, fewer each.
    for M in [1, 2, 4, 5]:
        add("M", f"M={M} F={M} N={round(9 * BASE['N'] / (M * M))}", M=M, F=M, N=round(9 * BASE["N"] / (M * M)))
    add("spt", "SPT off (same paths as base)", spt=0, nSpt=1)
    add("paper", "paper N=8000 k=40", k=40)
    add("paper", "paper N=8000 k=100", k=100)
    add("paper", "paper N=16000 k=40", N=16000, k=40)
    add("paper", "paper N=16000 k=100", N=16000, k=100)
    if tools.has_tree:
        # The default tree again, measured next to the others: the load changes over a sweep.
        for tree in ["middle", "median", "grid"]:
            add("tree", f"tree={tree}", tree=tree)
    # Accumulation: N x frames at k = 64, and at larger k, which is what lowers the noise once the
    # photon density is high (the estimate's relative noise ~ 1/sqrt(k F^2)).
    add("accumulate", "N=2000 x 4 frames", N=2000, frames=4)
    add("accumulate", "N=8000 x 4 frames", frames=4)
    add("accumulate", "N=8000 x 16 frames", frames=16)
    add("accumulate", "N=8000 k=200 x 4 frames", k=200, frames=4)
    add("accumulate", "N=8000 k=200 x 16 frames", k=200, frames=16)
    if scene == "RING":
        add("accumulate", "N=32000 k=400 x 8 frames", N=32000, k=400, frames=8)
    else:
        # GLASS paths cost ~3x RING's per stored photon: the large-N point stays affordable at k = 64.
        add("accumulate", "N=32000 x 4 frames", N=32000, frames=4)
    if not heavy:
        add("accumulate", "N=2000 x 16 frames", N=2000, frames=16)
    # Walkthrough: accumulate to a cap of ~3.5 frames' photons, then frames without shooting.
    add("walkthrough", "walkthrough after cap (~4 frames)", frames=8, cap=-1)
    # Cluster: the base point through rtpm-server + N rtpm-client on this machine.
    if tools.server.is_file() and tools.client.is_file():
        for c in [1, 2, 4]:
            add("clients", f"{c} client(s), 4 frames", frames=4, clients=c)
    if quick:
        pts = [p for p in pts if p[0] in ("default", "base", "paper")]
    return pts


def measure_render(tools, scene, pt, work, out):
    csv_path = work / "run.csv"
    csv_path.unlink(missing_ok=True)
    cpu0 = children_cpu()
    load1 = os.getloadavg()[0]
    rc, so, se = run_timed([str(tools.render)] + render_args(scene, pt, out, csv_path))
    cpu = children_cpu() - cpu0
    if rc != 0:
        raise RuntimeError(f"rtpm-render failed: {se.strip()}")
    rows = list(csv.DictReader(open(csv_path)))
    total = [float(r["total_ms"]) for r in rows]
    modes = [r["mode"] for r in rows]
    if pt["cap"] != 0 and "walkthrough" in modes:
        mode, sel = "walkthrough", [t for t, m in zip(total, modes) if m == "walkthrough"]
    elif len(rows) == 1:
        mode, sel = "interaction", total[:1]
    else:
        mode, sel = "accumulate", total[1:]
    ms = statistics.median(sel)
    res = dict(mode=mode, ms_per_frame=ms, fps=1000.0 / ms, cum_ms=sum(total),
               cpu_ms_per_frame=1000.0 * cpu / len(rows),
               photons_per_set=int(rows[-1]["photons"]) / (pt["M"] ** 2), load1=load1)
    res.update(compare(tools, out, tools.ref_path(scene)))
    return res


def measure_cluster(tools, scene, pt, work, out):
    csv_path = work / "cluster.csv"
    csv_path.unlink(missing_ok=True)
    env = dict(os.environ, RTPM_BUILD_DIR=str(tools.build))
    args = render_args(scene, pt, out, csv_path)
    args = [a for a in args if not a.startswith("--csv")]
    load1 = os.getloadavg()[0]
    # A generous deadline: every frame waits for all its sets, so the image is the full one.
    cmd = ["bash", str(ROOT / "deploy" / "run-local.sh"), f"--clients={pt['clients']}", f"--csv={csv_path}",
           "--deadline-ms=600000", "--quiet"] + args
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        # Seen once: rtpm-server died of SIGSEGV with one client; say so and try once more.
        log(f"{scene} {pt['clients']} client(s): run-local.sh failed ({r.stderr.strip()[-300:]}); retrying once")
        csv_path.unlink(missing_ok=True)
        r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        raise RuntimeError(f"run-local.sh failed: {r.stderr.strip()[-400:]}")
    rows = list(csv.DictReader(open(csv_path)))
    # The server pipelines frames, so its frame time is 1 / fps (throughput), not a latency.
    ms_all = [1000.0 / float(r["fps"]) for r in rows if float(r["fps"]) > 0]
    ms = statistics.median(ms_all[1:] if len(ms_all) > 1 else ms_all)
    res = dict(mode="accumulate", ms_per_frame=ms, fps=1000.0 / ms, cum_ms=sum(ms_all), cpu_ms_per_frame="",
               photons_per_set=float(rows[-1]["photons_per_set"]), load1=load1)
    res.update(compare(tools, out, tools.ref_path(scene)))
    return res


def write_results(rows):
    """Rewrites the CSV after every point, so an interrupted sweep keeps what it measured."""
    with open(RESULTS_CSV, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=FIELDS, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items() if k in FIELDS})


def slug(text):
    return "".join(c if c.isalnum() else "_" for c in text.lower()).strip("_")


def run_sweep(tools, scenes, quick, groups=None):
    for scene in scenes:
        if not tools.ref_path(scene).exists():
            sys.exit(f"sweep.py: no reference for {scene}; run sweep.py --make-references first")
    old = []
    if RESULTS_CSV.exists():
        old = [r for r in csv.DictReader(open(RESULTS_CSV))
               if r["scene"] not in scenes or (groups and r["group"] not in groups)]
    work = tools.cache / "work"
    work.mkdir(exist_ok=True)
    rows = []
    t0 = time.time()
    for scene in scenes:
        # With --groups, the yield and the cap come from the scene's stored default and base rows.
        prev = {r["group"]: r for r in old if r["scene"] == scene}
        yield0 = float(prev["default"]["photons_per_set"]) / float(prev["default"]["P"]) if "default" in prev else None
        cap_per_set = float(prev["base"]["photons_per_set"]) if "base" in prev else None
        for group, label, pt in sweep_points(scene, tools, quick):
            if groups and group not in groups:
                continue
            if pt["N"]:
                # SPT off keeps the base's paths (its lower yield is the point of the comparison).
                n = BASE["N"] if pt.pop("nSpt", 0) else pt["N"]
                pt = dict(pt, P=max(1, round(n / yield0)))
            if pt["cap"] == -1:
                pt = dict(pt, cap=max(1, int(3.5 * cap_per_set)))
            # Each point's image is kept so its error can be recomputed against a new reference
            # (--recompare) without re-running the point.
            out = work / f"{scene.lower()}_{slug(label)}.exr"
            try:
                if pt["clients"]:
                    res = measure_cluster(tools, scene, pt, work, out)
                else:
                    res = measure_render(tools, scene, pt, work, out)
            except RuntimeError as e:
                log(f"{scene} {label}: {e}")
                continue
            if group == "default":
                yield0 = res["photons_per_set"] / pt["P"]
                log(f"{scene}: frame-0 yield {100 * yield0:.1f} % stored photons per path")
            if group == "base":
                cap_per_set = res["photons_per_set"]
            row = dict(scene=scene, group=group, label=label, paper=int(group in ("paper", "base")),
                       width=WIDTH, height=HEIGHT, **pt)
            row.update(res)
            row["image"] = out.name
            rows.append(row)
            write_results(old + rows)
            log(f"[{time.time() - t0:6.0f} s] {scene:9s} {label:36s} {res['ms_per_frame']:8.1f} ms/frame  "
                f"rel_rmse {res['rel_rmse']:.4f}  energy {res['energy']:.3f}  load {res['load1']:.1f}")


def recompare(tools):
    """Recomputes every row's error against the current references from its kept image."""
    rows = list(csv.DictReader(open(RESULTS_CSV)))
    work = tools.cache / "work"
    for r in rows:
        img = work / r["image"]
        if not img.exists():
            sys.exit(f"sweep.py: {img} is gone; re-run the sweep")
        r.update({k: f"{v:.6g}" for k, v in compare(tools, img, tools.ref_path(r["scene"])).items()})
    write_results(rows)


# -------------------------------------------------------------------------------------- report

def pareto(points):
    """Indices of the points no other point beats in both coordinates (lower is better)."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    front, best = [], math.inf
    for i in order:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def loglog_at(xs, ys, x):
    """log-log interpolation of y at x on a front sorted by x; None outside the range."""
    for (x0, y0), (x1, y1) in zip(zip(xs, ys), zip(xs[1:], ys[1:])):
        if x0 <= x <= x1:
            t = (math.log(x) - math.log(x0)) / (math.log(x1) - math.log(x0)) if x1 > x0 else 0.0
            return math.exp(math.log(y0) + t * (math.log(y1) - math.log(y0)))
    return None


def slope_fit(xs, ys):
    """Least-squares slope and intercept of log y against log x."""
    lx, ly = [math.log(v) for v in xs], [math.log(v) for v in ys]
    mx, my = statistics.fmean(lx), statistics.fmean(ly)
    sxx = sum((a - mx) ** 2 for a in lx)
    if sxx == 0:
        return None
    b = sum((a - mx) * (c - my) for a, c in zip(lx, ly)) / sxx
    return b, my - b * mx


def time_to_error(front_t, front_e, target):
    """Time at which the front reaches `target` error: ('interpolated'|'extrapolated'|'never', t, note)."""
    for (t0, e0), (t1, e1) in zip(zip(front_t, front_e), zip(front_t[1:], front_e[1:])):
        if e1 <= target <= e0:
            u = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0)) if e1 < e0 else 0.0
            return "interpolated", math.exp(math.log(t0) + u * (math.log(t1) - math.log(t0)))
    if front_e and front_e[0] <= target:
        return "reached at the fastest point", front_t[0]
    tail = list(zip(front_t, front_e))[-3:]
    fit = slope_fit([a for a, _ in tail], [b for _, b in tail]) if len(tail) >= 2 else None
    # A front flatter than error ~ t^-0.2 has met a floor (blur the photon count cannot remove, or
    # the reference's own noise); its extrapolation would be meaningless.
    if fit and fit[0] < -0.2:
        b, a = fit
        return f"extrapolated (slope {b:.2f} over the last {len(tail)} front points)", math.exp(
            (math.log(target) - a) / b)
    return "not reached; the front has flattened", None


def fmt_ms(v):
    return "—" if v is None else (f"{v / 1000:.1f} s" if v >= 10000 else f"{v:.0f} ms")


def report(tools_meta, machine):
    rows = list(csv.DictReader(open(RESULTS_CSV)))
    for r in rows:
        for k in ("ms_per_frame", "cum_ms", "rel_rmse", "energy", "rel_mae", "fps", "load1", "photons_per_set"):
            r[k] = float(r[k])
        for k in ("paper", "N", "P", "k", "M", "F", "spt", "frames", "clients", "cap"):
            r[k] = int(float(r[k]))
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    md = ["# Speed against error: the sweep", "",
          "Generated by `tests/bench/sweep.py` (run with `tests/bench/sweep.sh`); data in "
          "[sweep_results.csv](sweep_results.csv). Do not edit by hand.", ""]
    md += machine
    md += ["", "## How to read it", "",
           "* **N** = stored caustic photons per interleaving set and frame, the paper's count (Fig. 4: "
           "8000–16000 photons per client; Table 6: RING 81k photons in interaction = 9k per set). rtpm's "
           "`-P` counts light *paths* per set, of which only the yield stores a photon (RING/GLASS a few "
           "%, HEADLIGHT ~60 %), so each point runs P = N / (frame-0 yield at P = 20000); **P** and the "
           "measured photons/set are in the table. Bold rows are the paper's operating points.",
           f"* Resolution {WIDTH}×{HEIGHT} for every point and reference (2 shared cores: a 640×480 sweep "
           "would not fit the time box). Per-pixel error depends little on resolution at fixed settings; "
           "time per frame of the eye pass scales with the pixel count (≈4× at 640×480), photon shooting "
           "does not.",
           "* **error** = relative RMSE of `caustic_filtered` over the reference's caustic region "
           "(rtpm-compare: pixels above 5 % of the 99th percentile), **energy** = Σ output / Σ reference "
           "over the image. Reference: see the table below; its own noise (floor) is half the "
           "rel. RMSE between its two seeds, so errors near the floor are not resolved.",
           "* **ms/frame** = median `total_ms` (wall) of the frames in the row's mode: *interaction* = "
           "frame 0 after a reset (what a moving camera sees), *accumulate* = frames 1..N−1, "
           "*walkthrough* = frames after the photon cap. **to image** = Σ total_ms from reset to the "
           "measured frame. **cpu ms/frame** = the process's CPU time (all threads, start-up "
           "included) / frames: steadier than wall time under load.",
           "* Cluster rows (`clients`) run rtpm-server + N rtpm-client on the same 2 cores: they show the "
           "distribution overhead, not a speed-up; their time is 1/fps of the pipelined server. They "
           "are left out of the fronts.",
           "* **Pareto (frame)**: no other single-frame (interaction) point is both faster per frame and "
           "more accurate — the error at 10 fps is interpolated (log-log) on this front. "
           "**Pareto (image)**: over all single-process points, time from reset to the image against "
           "its error — the time to reach 2 % is read off this front.", ""]
    refs = tools_meta or {}
    if refs:
        md += ["## References", "", "| scene | P per set × frames | k | seeds | photons (both seeds) | "
               "floor (rel. RMSE) | seed energy ratio | wall |", "|---|---|---|---|---|---|---|---|"]
        for s in SCENES:
            if s in refs:
                m = refs[s]
                st = m["settings"]
                md.append(f"| {s} | {st['P']} × {st['frames']} | {st['k']} | {len(st['seeds'])} | "
                          f"{m['photons_total']:,} | {m['floor_rel_rmse']:.4f} | {m['seed_energy_ratio']:.4f} | "
                          f"{m['wall_s']:.0f} s |")
        md.append("")
    headline = {}
    for scene in SCENES:
        sr = [r for r in rows if r["scene"] == scene]
        if not sr:
            continue
        single = [r for r in sr if r["clients"] == 0]
        inter = [r for r in single if r["mode"] == "interaction"]
        f_frame = [inter[i] for i in pareto([(r["ms_per_frame"], r["rel_rmse"]) for r in inter])]
        f_image = [single[i] for i in pareto([(r["cum_ms"], r["rel_rmse"]) for r in single])]
        for r in f_frame:
            r["front_frame"] = True
        for r in f_image:
            r["front_image"] = True
        ft, fe = [r["ms_per_frame"] for r in f_frame], [r["rel_rmse"] for r in f_frame]
        e10 = loglog_at(ft, fe, TARGET_MS)
        if e10 is not None:
            e10_text = f"{e10:.3f} (interpolated on the frame front)"
        elif ft and TARGET_MS < ft[0]:
            # No extrapolation: below the fastest point the error is set by what a frame can hold
            # (too few photons for the gather radius), which the slope of the front does not predict.
            e10_text = (f"not reached at {WIDTH}×{HEIGHT} on this machine: the fastest point takes {ft[0]:.0f} "
                        f"ms/frame ({1000 / ft[0]:.1f} fps) with error {fe[0]:.3f}")
        else:
            e10_text = f"{fe[-1]:.3f} (every front point is faster than 10 fps; the most accurate)"
        how, t2 = time_to_error([r["cum_ms"] for r in f_image], [r["rel_rmse"] for r in f_image], TARGET_ERROR)
        best = min(single, key=lambda r: r["rel_rmse"])
        base = next((r for r in sr if r["group"] == "base"), None)
        dflt = next((r for r in sr if r["group"] == "default"), None)
        headline[scene] = dict(e10=e10_text, t2=t2, t2how=how, best=best, base=base, dflt=dflt)
        md += [f"## {scene}", "",
               f"* error at 10 fps (interaction): **{e10_text}**",
               f"* time from reset to 2 % error: **{fmt_ms(t2)}** — {how}; best error reached "
               f"{best['rel_rmse']:.4f} ({best['label']}, {fmt_ms(best['cum_ms'])} to the image)"]
        if base:
            md.append(f"* paper operating point (N = 8000 stored photons per set, P = {base['P']} paths, k = 64, 3×3, "
                      f"F = 3, SPT): {base['ms_per_frame']:.0f} "
                      f"ms/frame ({base['fps']:.1f} fps), error {base['rel_rmse']:.3f}, energy {base['energy']:.3f}")
        if scene in refs:
            md.append(f"* reference floor ≈ {refs[scene]['floor_rel_rmse']:.4f}")
        if dflt:
            md.append(f"* rtpm defaults (P = 20000 paths per set, k = 64, 3×3, F = 3, SPT) at {WIDTH}×{HEIGHT}: "
                      f"{dflt['ms_per_frame']:.0f} ms/frame ({dflt['fps']:.1f} fps), {dflt['photons_per_set']:.0f} "
                      f"photons per set, error {dflt['rel_rmse']:.3f}, energy {dflt['energy']:.3f}")
        md += ["", f"![{scene}](sweep_{scene.lower()}.png)", "",
               "| group | setting | N | P | k | M | F | SPT | frames | mode | ms/frame | fps | to image | "
               "cpu ms/frame | photons/set | error | energy | load | Pareto |",
               "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in sr:
            marks = []
            if r.get("front_frame"):
                marks.append("frame")
            if r.get("front_image"):
                marks.append("image")
            label = f"**{r['label']}**" if r["paper"] else r["label"]
            cpu = f"{float(r['cpu_ms_per_frame']):.0f}" if r["cpu_ms_per_frame"] else "—"
            md.append(f"| {r['group']} | {label} | {r['N'] or '—'} | {r['P']} | {r['k']} | {r['M']} | {r['F']} | "
                      f"{'on' if r['spt'] else 'off'} | {r['frames']} | {r['mode']} | {r['ms_per_frame']:.0f} | "
                      f"{r['fps']:.2f} | {fmt_ms(r['cum_ms'])} | {cpu} | {r['photons_per_set']:.0f} | "
                      f"{r['rel_rmse']:.4f} | {r['energy']:.3f} | {r['load1']:.1f} | {' '.join(marks) or ''} |")
        md.append("")
        plot(plt, scene, sr, single, f_frame, f_image, refs.get(scene))
    SWEEP_MD.write_text("\n".join(md) + "\n")
    return headline


def plot(plt, scene, sr, single, f_frame, f_image, ref):
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.4), dpi=80)
    styles = {"interaction": ("o", "C0"), "accumulate": ("s", "C1"), "walkthrough": ("^", "C2")}
    for r in sr:
        m, c = styles[r["mode"]]
        if r["clients"]:
            m, c = "D", "C4"
        edge, lw = ("k", 1.5) if r["paper"] else ("none", 0.0)
        a.scatter(r["ms_per_frame"], r["rel_rmse"], marker=m, c=c, edgecolors=edge, linewidths=lw, s=36, zorder=3)
        if r["clients"] == 0:
            b.scatter(r["cum_ms"], r["rel_rmse"], marker=m, c=c, edgecolors=edge, linewidths=lw, s=36, zorder=3)
    a.plot([r["ms_per_frame"] for r in f_frame], [r["rel_rmse"] for r in f_frame], "k-", lw=1,
           label="Pareto front (interaction)")
    b.plot([r["cum_ms"] for r in f_image], [r["rel_rmse"] for r in f_image], "k-", lw=1, label="Pareto front")
    for r in f_frame:
        a.annotate(r["label"].replace("paper ", ""), (r["ms_per_frame"], r["rel_rmse"]), fontsize=6,
                   xytext=(3, 3), textcoords="offset points")
    for r in f_image:
        b.annotate(r["label"].replace("paper ", ""), (r["cum_ms"], r["rel_rmse"]), fontsize=6,
                   xytext=(3, 3), textcoords="offset points")
    a.axvline(TARGET_MS, color="grey", ls=":", lw=1, label="10 fps")
    for ax in (a, b):
        ax.axhline(TARGET_ERROR, color="red", ls=":", lw=1, label="2 % error")
        if ref:
            ax.axhline(ref["floor_rel_rmse"], color="grey", ls="--", lw=0.8, label="reference floor")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
        ax.set_ylabel("relative RMSE, caustic region")
    for mode, (m, c) in styles.items():
        a.scatter([], [], marker=m, c=c, label=mode)
    a.scatter([], [], marker="D", c="C4", label="cluster (N clients)")
    a.set_xlabel("time per frame, ms (wall, median)")
    b.set_xlabel("time from reset to the image, ms (wall)")
    a.set_title(f"{scene} {WIDTH}×{HEIGHT}: per frame (black edge = paper's operating points)", fontsize=9)
    b.set_title(f"{scene}: convergence", fontsize=9)
    a.legend(fontsize=6, loc="lower left")
    b.legend(fontsize=6, loc="lower left")
    fig.tight_layout()
    fig.savefig(BENCH / f"sweep_{scene.lower()}.png")
    plt.close(fig)


def machine_lines(start_load=None):
    cpu = "unknown CPU"
    try:
        cpu = next(l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name"))
    except (OSError, StopIteration):
        pass
    info = {}
    meta = BENCH / "sweep_machine.json"
    if meta.exists():
        info = json.loads(meta.read_text())
    lines = [f"Machine: `nproc` = {info.get('nproc', os.cpu_count())}, {info.get('cpu', cpu)}. "
             f"Load average (uptime) at the start of the sweep: {info.get('load_start', '?')}, at the end: "
             f"{info.get('load_end', '?')}; sweep wall time {info.get('wall_s', '?')} s; commit "
             f"{info.get('commit', '?')}. {info.get('note', '')}",
             "Other jobs shared the 2 cores: wall times are inflated and noisy (the `load` column is the "
             "1-minute load average when the point started); ratios between neighbouring rows and the "
             "CPU-time column are more trustworthy than absolute fps."]
    return lines


def main():
    global BENCH, RESULTS_CSV, SWEEP_MD, WIDTH, HEIGHT
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.environ.get("RTPM_BUILD_DIR", str(ROOT / "build")))
    ap.add_argument("--make-references", action="store_true")
    ap.add_argument("--run", action="store_true")
    ap.add_argument("--report", action="store_true")
    ap.add_argument("--recompare", action="store_true",
                    help="recompute the errors of the CSV's points (kept images) against the references")
    ap.add_argument("--quick", action="store_true", help="only the base and paper points (smoke test)")
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--groups", default="", help="run only these groups (comma-separated, e.g. tree); "
                    "the CSV keeps the other rows")
    ap.add_argument("--out", default=str(BENCH), help="folder of the CSV, SWEEP.md, the PNGs and the JSON notes")
    ap.add_argument("--cache", default="", help="folder of the references and images (default BUILD/sweep-cache)")
    ap.add_argument("--size", default=f"{WIDTH}x{HEIGHT}", help="WxH of every point and reference")
    ap.add_argument("--ref-photons", type=int, default=0, help="paths per set of each reference frame "
                    "(default: REFERENCES, millions)")
    a = ap.parse_args()
    BENCH = Path(a.out).resolve()
    BENCH.mkdir(parents=True, exist_ok=True)
    RESULTS_CSV, SWEEP_MD = BENCH / "sweep_results.csv", BENCH / "SWEEP.md"
    try:
        WIDTH, HEIGHT = (int(v) for v in a.size.lower().split("x"))
    except ValueError:
        sys.exit(f"sweep.py: --size must be WxH, not {a.size}")
    scenes = [s.strip().upper() for s in a.scenes.split(",") if s.strip()]
    for s in scenes:
        if s not in SCENES:
            sys.exit(f"sweep.py: unknown scene {s} (known: {', '.join(SCENES)})")
    if not (a.make_references or a.run or a.report or a.recompare):
        ap.error("nothing to do: give --make-references, --run, --recompare and/or --report")
    tools = Tools(a.build, a.cache) if (a.make_references or a.run or a.recompare) else None
    if a.make_references:
        make_references(tools, scenes, a.ref_photons)
    if a.run:
        if not tools.has_tree:
            log("rtpm-render has no --tree flag: the tree variants are skipped")
        t0 = time.time()
        load_start = " ".join(f"{v:.2f}" for v in os.getloadavg())
        run_sweep(tools, scenes, a.quick, [g for g in a.groups.split(",") if g] or None)
        commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True).stdout.strip()
        if not a.groups:  # a partial re-run (--groups) keeps the full sweep's machine note
            (BENCH / "sweep_machine.json").write_text(json.dumps(dict(
                nproc=os.cpu_count(), cpu=next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo")
                                                if l.startswith("model name")), "?"),
                load_start=load_start, load_end=" ".join(f"{v:.2f}" for v in os.getloadavg()),
                wall_s=round(time.time() - t0), commit=commit, tree_flag=tools.has_tree), indent=1) + "\n")
    if a.recompare:
        recompare(tools)
    if a.report or a.run or a.recompare:
        build = Path(a.build).resolve()
        meta_path = (Path(a.cache).resolve() if a.cache else build / "sweep-cache") / "references.json"
        refs = json.loads(meta_path.read_text()) if meta_path.exists() else {}
        stored = BENCH / "sweep_references.json"
        if refs:
            stored.write_text(json.dumps(refs, indent=1) + "\n")
        elif stored.exists():
            refs = json.loads(stored.read_text())
        headline = report(refs, machine_lines())
        for s, h in headline.items():
            log(f"{s}: error at 10 fps {h['e10']}; time to 2 %: {fmt_ms(h['t2'])} ({h['t2how']})")


if __name__ == "__main__":
    main()
