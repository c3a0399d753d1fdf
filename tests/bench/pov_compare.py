#!/usr/bin/python3
"""rtpm against POV-Ray 3.7 photon mapping on the curved-mirror scene, in one run.

Writes the scene of tests/support/ring_mirror.h (smooth cylindrical mirror, radius 1 m, height
0.35 m, reflectance 0.9; floor albedo 0.8; point light of 3 W/sr at (0.55, 0.9, 0); camera 4 m
above the centre looking down, vertical field of view 0.537 rad, +z at the image bottom) as POV
SDL, renders it with POV-Ray at several photon counts and rtpm (tests/bench/ring_mirror_bench,
the progressive estimator, L S D photon paths) for a time budget, and scores both with the same
analytic reference (caustic-region rel. MAE, ring_mirror_bench --compare). POV-Ray's caustic is
its photon render minus the same render without photons (the direct light is deterministic).
--light=X,Y,Z and --ring-height H render and score a variant of the scene (the same values for
both renderers and the reference; with the "=", a negative X is not read as an option).

Units: POV-Ray's diffuse term is pigment × diffuse × light colour × attenuation × cos θ, with no
1/π, and its fade is 2 / (1 + (d / fade_distance)^fade_power). rtpm's radiance is
ρ/π · I cos θ / d². With fade_power 2 and fade_distance D ≪ d the attenuation is 2 D²/d², so the
light colour I / (2π D²) gives rtpm's radiance to a relative 1e-6 (D = 1 mm).

Times: POV-Ray's are whole processes (parse, photon shooting, render; -WT2 threads); rtpm's are
taken inside ring_mirror_bench from the RenderJob's construction (BVH build included), per frame.
Wall and CPU (user + sys) are both reported: the machine may be shared.

POV-Ray runs at each photon count and gather setting (MIN:MAX photons per estimate; its spacing
follows from the count); its best curve is the least time to each error. rtpm runs at the
defaults a user gets (M 3, P 20 000, still frames held to the 16.7 ms budget) with both estimators.

    /usr/bin/python3 tests/bench/pov_compare.py --build build --seconds 60 --out tests/bench
"""
import argparse
import csv
import math
import os
import resource
import subprocess
import sys
import tempfile
import time

SDL = """#version 3.7;
#ifndef (PhotonCount) #declare PhotonCount = 500000; #end
#ifndef (UsePhotons) #declare UsePhotons = 1; #end
#ifndef (GatherMin) #declare GatherMin = 20; #end
#ifndef (GatherMax) #declare GatherMax = 100; #end
global_settings {
  assumed_gamma 1.0
  max_trace_level 5
  #if (UsePhotons) photons { count PhotonCount gather GatherMin, GatherMax autostop 0 jitter 0
    max_trace_level 2 } #end
}
// rtpm's camera: +x to the right, +z at the image bottom; right -x makes the frame right-handed.
camera { perspective location <0, 4, 0> look_at <0, 0, 0> sky <0, 0, -1>
  right -x*WIDTH/HEIGHT angle degrees(2*atan(tan(0.537/2)*WIDTH/HEIGHT)) }
#declare FD = 0.001;  // fade_distance: attenuation 2 FD^2 / d^2
light_source { <LIGHT> color rgb 3/(2*pi*FD*FD) fade_distance FD fade_power 2
  photons { reflection on refraction off } }
plane { y, 0
  texture { pigment { color rgb 0.8 } finish { ambient 0 emission 0 diffuse 1 specular 0 } }
  photons { collect on } }
cylinder { <0, 0, 0>, <0, RING_HEIGHT, 0>, 1 open
  texture { pigment { color rgb 0 } finish { ambient 0 emission 0 diffuse 0 reflection { 0.9 } } }
  photons { target reflection on collect off } }
"""


def timed(cmd):
    """Runs cmd; returns (wall s, CPU s of the child, stdout)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.monotonic()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.monotonic() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        sys.exit(f"pov_compare: {' '.join(cmd)} failed ({p.returncode}):\n{p.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, p.stdout


def sdl(width, height, light="0.55,0.9,0", ring_height=0.35):
    """The scene as POV SDL at this image size, with the light at X,Y,Z and the mirror this high."""
    return (SDL.replace("RING_HEIGHT", str(ring_height)).replace("WIDTH", str(width))
            .replace("HEIGHT", str(height)).replace("<LIGHT>", "<" + ", ".join(light.split(",")) + ">"))


def score(bench, image, minus=None, variant=()):
    cmd = [bench, "--compare", image] + (["--minus", minus] if minus else []) + list(variant)
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout.split()
    return float(out[1]), float(out[3])


def time_to(points, target):
    """Log-log interpolated time at which the error first falls to target (None if never)."""
    for (t0, e0), (t1, e1) in zip(points, points[1:]):
        if e0 > target >= e1:
            a = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + a * (math.log(t1) - math.log(t0)))
    return points[0][0] if points and points[0][1] <= target else None


def error_at(points, t):
    """Log-log interpolated error at time t (None outside the measured range)."""
    for (t0, e0), (t1, e1) in zip(points, points[1:]):
        if t0 <= t <= t1:
            a = (math.log(t) - math.log(t0)) / (math.log(t1) - math.log(t0))
            return math.exp(math.log(e0) + a * (math.log(e1) - math.log(e0)))
    return None


def slope(points):
    xs = [math.log(t) for t, _ in points]
    ys = [math.log(e) for _, e in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    return -sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build", help="rtpm build folder")
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--pov-photons",
                    default="125000,250000,500000,1000000,2000000,4000000,8000000,16000000",
                    help="POV-Ray photon counts, comma-separated")
    ap.add_argument("--pov-gather", default="20:100,10:50,50:200",
                    help="POV-Ray gather MIN:MAX settings, comma-separated (20:100 is its default)")
    ap.add_argument("--rtpm", default="progressive:3:20000:16.7,knn:3:20000:16.7",
                    help="rtpm runs ESTIMATOR:M:P:BUDGET_MS, comma-separated (the defaults: M 3, "
                         "P 20 000, still frames held to the 16.7 ms budget)")
    ap.add_argument("--seconds", type=float, default=60.0, help="rtpm wall-time budget per run")
    ap.add_argument("--out", default="tests/bench", help="folder for pov_compare.csv and .png")
    ap.add_argument("--light", default="0.55,0.9,0",
                    help="a variant of the scene: the point light at X,Y,Z (inside the ring, above the floor)")
    ap.add_argument("--ring-height", type=float, default=0.35, help="a variant of the scene: the mirror's height (m)")
    a = ap.parse_args()
    variant = ["--light", a.light, "--ring-height", str(a.ring_height)]
    bench = os.path.join(a.build, "tests/bench/ring_mirror_bench")
    if not os.access(bench, os.X_OK):
        sys.exit(f"pov_compare: {bench} not found: build the ring_mirror_bench target")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        sdl_path = os.path.join(tmp, "ring_mirror.pov")
        with open(sdl_path, "w") as f:
            f.write(sdl(a.width, a.height, a.light, a.ring_height))
        pov = ["povray", f"+I{sdl_path}", "+FE", f"+W{a.width}", f"+H{a.height}", "-A", "-D", "+WT2"]
        direct = os.path.join(tmp, "direct.exr")
        timed(pov + [f"+O{direct}", "Declare=UsePhotons=0"])
        for gather in a.pov_gather.split(","):
            gmin, gmax = (int(x) for x in gather.split(":"))
            for n in [int(x) for x in a.pov_photons.split(",")]:
                img = os.path.join(tmp, f"pov_{gmin}_{gmax}_{n}.exr")
                wall, cpu, _ = timed(pov + [f"+O{img}", f"Declare=PhotonCount={n}", f"Declare=GatherMin={gmin}",
                                            f"Declare=GatherMax={gmax}"])
                err, energy = score(bench, img, direct, variant)
                rows.append((f"POV-Ray gather {gmin},{gmax}", f"{n} photons", wall, cpu, err, energy))
                print(f"POV-Ray gather {gmin},{gmax} {n:>8} photons: wall {wall:6.2f} s, CPU {cpu:6.2f} s, "
                      f"rel. MAE {err:.4f}, energy {energy:.3f}", flush=True)
        for run in a.rtpm.split(","):
            estimator, m, p, budget = run.split(":")
            rcsv = os.path.join(tmp, f"rtpm_{estimator}_{m}_{p}.csv")
            timed([bench, "--estimator", estimator, "--photons", p, "-M", m, "--frame-budget-ms", budget,
                   "--frames", "100000", "--seconds", str(a.seconds), "--width", str(a.width), "--height",
                   str(a.height), "--csv", rcsv] + variant)
            name = f"rtpm {estimator} M={m} P={p}" + (f" budget {budget} ms" if budget != "0" else "")
            with open(rcsv) as f:
                for r in csv.DictReader(f):
                    rows.append((name, f"{r['frame']} frames", float(r["wall_s"]), float(r["cpu_s"]),
                                 float(r["rel_mae"]), float(r["energy"])))
                    print(f"{name} {r['frame']:>5} frames: wall {float(r['wall_s']):6.2f} s, CPU "
                          f"{float(r['cpu_s']):6.2f} s, rel. MAE {float(r['rel_mae']):.4f}, "
                          f"energy {float(r['energy']):.3f}", flush=True)
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(a.out, "pov_compare.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["renderer", "setting", "wall_s", "cpu_s", "rel_mae", "energy"])
        for r in rows:
            w.writerow([r[0], r[1], f"{r[2]:.3f}", f"{r[3]:.3f}", f"{r[4]:.5f}", f"{r[5]:.4f}"])

    print("\n| renderer | setting | wall s | CPU s | caustic rel. MAE | energy |\n|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]:.2f} | {r[3]:.2f} | {r[4]:.4f} | {r[5]:.3f} |")
    names = list(dict.fromkeys(r[0] for r in rows if r[0].startswith("rtpm")))
    povs = list(dict.fromkeys(r[0] for r in rows if r[0].startswith("POV-Ray")))
    for clock, col in (("wall", 2), ("CPU", 3)):
        for target in (0.05, 0.02):
            # POV-Ray's best setting for this target: the least time to reach it.
            best = None
            for pname in povs:
                pts = sorted((r[col], r[4]) for r in rows if r[0] == pname)
                t = time_to(pts, target)
                if t is not None and (best is None or t < best[1]):
                    best = (pname, t)
            print(f"\n{clock}: POV-Ray time to rel. MAE {target}: "
                  + (f"{best[1]:.2f} s ({best[0]})" if best else "not reached"))
            for name in names:
                rt = [(r[col], r[4]) for r in rows if r[0] == name]
                tr = time_to(rt, target)
                print(f"{clock}: {name} time to rel. MAE {target}: " + (f"{tr:.2f} s" if tr else "not reached")
                      + (f", ratio to POV-Ray's best {tr / best[1]:.2f}" if best and tr else ""))
        for pname in povs:
            pts = sorted((r[col], r[4]) for r in rows if r[0] == pname)
            # One photon count (or equal times) gives no exponent to fit.
            fit = f"{slope(pts):.3f}" if len({t for t, _ in pts}) >= 2 else "n/a (one time)"
            print(f"{clock}: {pname}: fitted exponent (error ~ time^-e) {fit}, "
                  f"lowest error {min(p[1] for p in pts):.4f}")
        for name in names:
            late = [(r[col], r[4]) for r in rows if r[0] == name and r[col] >= 1.0]
            if len(late) >= 2:
                print(f"{clock}: {name} fitted exponent over t >= 1 s {slope(late):.3f}")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for name, marker in [(n, "o-") for n in names] + [(n, "s--") for n in povs]:
        pts = sorted((r[2], r[4]) for r in rows if r[0] == name)
        ax.loglog([p[0] for p in pts], [p[1] for p in pts], marker, label=f"{name} (wall)")
    ax.axhline(0.05, color="grey", lw=0.8, ls=":")
    ax.axhline(0.02, color="grey", lw=0.8, ls=":")
    ax.set_xlabel("wall time (s)")
    ax.set_ylabel("caustic-region rel. MAE vs analytic reference")
    ax.set_title(f"curved mirror, {a.width}×{a.height}")
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "pov_compare.png"), dpi=100)
    print(f"\nwrote {os.path.join(a.out, 'pov_compare.csv')} and pov_compare.png")


if __name__ == "__main__":
    main()
