#!/usr/bin/env python3
"""Renders every glTF file under a folder as a new user would (rtpm-render, no flags but the
size, one frame) and says which render, which are refused and which come out black or nearly.

    tests/bench/gltf_corpus.py DIR [--build BUILD] [--size 160x120] [--out OUT]

A file renders when rtpm-render exits 0; it is dark when the mean of its tone-mapped PNG (the
picture a user opens, channels in [0, 1]) is below 0.02. Prints one markdown row per file (exit
status, mean, the first warning or the error) and a summary line:
"renders N of M without flags, D of them dark (mean < 0.02)". Exit status 0 whatever the
verdicts (a survey, not a test); 2 on bad arguments. OUT (default: a temporary folder, removed)
keeps the pictures and logs.

Meant for a folder of exports, e.g. Blender's glTF exporter's round-trip files exported again by
Blender, or your own scenes. The PNG reader below handles what rtpm-render writes (8-bit RGB or
RGBA, not interlaced).
"""
import argparse
import os
import pathlib
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

DARK = 0.02


def png_mean(path):
    """Mean of every channel of an 8-bit RGB(A) PNG, alpha left out, in [0, 1]."""
    data = pathlib.Path(path).read_bytes()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG")
    pos, idat, width = 8, b"", 0
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if depth != 8 or colour not in (2, 6) or interlace:
                raise ValueError(f"{path}: only 8-bit RGB/RGBA, not interlaced")
            channels = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
    raw = zlib.decompress(idat)
    stride = width * channels
    prev = bytearray(stride)
    total, count = 0, 0
    for y in range(height):
        row = raw[y * (stride + 1):(y + 1) * (stride + 1)]
        kind, cur = row[0], bytearray(row[1:])
        for i in range(stride):
            a = cur[i - channels] if i >= channels else 0
            b = prev[i]
            c = prev[i - channels] if i >= channels else 0
            if kind == 1:
                cur[i] = (cur[i] + a) & 255
            elif kind == 2:
                cur[i] = (cur[i] + b) & 255
            elif kind == 3:
                cur[i] = (cur[i] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                cur[i] = (cur[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        for x in range(width):
            px = cur[x * channels:x * channels + 3]
            total += px[0] + px[1] + px[2]
        count += 3 * width
        prev = cur
    return total / (255.0 * count)


def first_line(log, prefix):
    for line in log.splitlines():
        if line.startswith(prefix):
            return line
    return ""


def main():
    root = pathlib.Path(__file__).resolve().parents[2]
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dir")
    ap.add_argument("--build", default=str(root / "build"))
    ap.add_argument("--size", default="160x120")
    ap.add_argument("--out")
    args = ap.parse_args()
    render = pathlib.Path(args.build) / "common" / "cmd" / "rtpm-render"
    if not render.is_file():
        print(f"gltf_corpus.py: {render} missing (build rtpm-render)", file=sys.stderr)
        return 2
    try:
        width, height = (int(v) for v in args.size.split("x"))
    except ValueError:
        print(f"gltf_corpus.py: --size must be WxH, not '{args.size}'", file=sys.stderr)
        return 2
    files = sorted(p for p in pathlib.Path(args.dir).rglob("*") if p.suffix.lower() in (".gltf", ".glb"))
    if not files:
        print(f"gltf_corpus.py: no .gltf or .glb file under {args.dir}", file=sys.stderr)
        return 2
    out = pathlib.Path(args.out) if args.out else pathlib.Path(tempfile.mkdtemp(prefix="rtpm-corpus."))
    out.mkdir(parents=True, exist_ok=True)
    print(f"### {len(files)} files under {args.dir}, {width}x{height}, 1 frame, no other flag\n")
    print("| file | exit | mean | first warning or error |")
    print("|---|---|---|---|")
    rendered = dark = 0
    try:
        for i, f in enumerate(files):
            stem = out / f"{i:03d}_{f.stem}"
            proc = subprocess.run([str(render), "--scene", str(f), "--width", str(width), "--height", str(height),
                                   "--frames", "1", "--out", f"{stem}.exr"],
                                  capture_output=True, text=True, timeout=600)
            log = proc.stdout + proc.stderr
            (stem.parent / (stem.name + ".log")).write_text(log)
            mean = ""
            if proc.returncode == 0:
                rendered += 1
                m = png_mean(f"{stem}.png")
                mean = f"{m:.4f}"
                if m < DARK:
                    dark += 1
                    mean += " dark"
                note = first_line(log, "warning:")
            else:
                note = first_line(log, "rtpm-render:") or log.strip().splitlines()[-1:]
            note = str(note).replace("|", "/").replace(str(f), f.name)[:160]
            print(f"| {f.relative_to(args.dir)} | {proc.returncode} | {mean} | {note} |")
    finally:
        if not args.out:
            shutil.rmtree(out, ignore_errors=True)
    print(f"\nrenders {rendered} of {len(files)} without flags, {dark} of them dark (mean < {DARK})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
