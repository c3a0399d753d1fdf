#!/usr/bin/env python3
"""Hostile probes of rtpm-server's viewer port (--http) and the cluster port's admission, the
figures of RESULTS.md "Viewer port hardening". Loopback only; every server is started here and
stopped (SIGTERM, then SIGKILL) before the next probe.

  tests/bench/viewer_port_probe.py BUILD_DIR [probe ...]
  probes: origin fds guesses tokenless insecure rebinding nodes nat   (default: all)

Each takes up to 5 s but fds (about 30 s: 1 000 connections, then 7 s) and nat (about 50 s: 20 s
of frames with one client, alone and beside the flood); bench-smoke runs all but those two.
Prints one line per figure: "probe: figure".
"""
import atexit
import os
import re
import resource
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time

if len(sys.argv) > 1 and sys.argv[1] in ("-h", "--help"):
    print(__doc__.strip())
    sys.exit(0)
TOKEN = "5f2c8d0a9b7e4c1f3a6d8e2b0c9f7a14"  # `openssl rand -hex 16`
BUILD = sys.argv[1] if len(sys.argv) > 1 else "build"
SERVER = os.path.join(BUILD, "server/rtpm-server")
CLIENT = os.path.join(BUILD, "client/rtpm-client")
WORK = tempfile.mkdtemp(prefix="rtpm-viewer-probe.")
atexit.register(shutil.rmtree, WORK, True)  # the nodes probe alone leaves a 42 MB glTF


def say(probe, text):
    print(f"{probe}: {text}", flush=True)


class Server:
    def __init__(self, extra=(), env_token=True, name="server", frames="0", size=("64", "48")):
        self.err_path = os.path.join(WORK, name + ".err")
        self.out_path = os.path.join(WORK, name + ".out")
        port_file = os.path.join(WORK, name + ".port")
        if os.path.exists(port_file):
            os.remove(port_file)
        env = dict(os.environ)
        if env_token:
            env["RTPM_TOKEN"] = TOKEN
        argv = [SERVER, "--port", "0", "--port-file", port_file, "--scene", "RING", "--width", size[0],
                "--height", size[1], "-M", "2", "-P", "500", "--frames", frames,
                "--out", os.path.join(WORK, name + ".exr")] + list(extra)
        self.proc = subprocess.Popen(argv, stdout=open(self.out_path, "wb"), stderr=open(self.err_path, "wb"),
                                     env=env)
        self.port = self.http = 0
        end = time.time() + 60
        while time.time() < end and self.proc.poll() is None:
            out = open(self.out_path, "rb").read().decode(errors="replace")
            m = re.search(r"listening on [^:]+:(\d+)", out)
            h = re.search(r"viewer: http://[^:]+:(\d+)/", out)
            if m and (h or "--http" not in extra):
                self.port, self.http = int(m.group(1)), int(h.group(1)) if h else 0
                return
            time.sleep(0.05)

    def err(self):
        return open(self.err_path, "rb").read()

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        return self.proc.returncode


def connect(port, source="127.0.0.1", timeout=5.0):
    s = socket.socket()
    s.settimeout(timeout)
    s.bind((source, 0))
    s.connect(("127.0.0.1", port))
    return s


def upgrade(s, origin=None, host="127.0.0.1"):
    req = ("GET /ws HTTP/1.1\r\nHost: " + host + "\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
           "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n")
    if origin is not None:
        req += "Origin: " + origin + "\r\n"
    s.sendall((req + "\r\n").encode("latin-1"))
    head = b""
    while b"\r\n\r\n" not in head:
        chunk = s.recv(4096)
        if not chunk:
            return 0, b""
        head += chunk
    status = int(head.split(b" ", 2)[1])
    return status, head.split(b"\r\n\r\n", 1)[1]


def send_text(s, text):
    data = text.encode()
    header = bytes([0x81]) + (bytes([0x80 | len(data)]) if len(data) < 126 else bytes([0x80 | 126]) +
                              len(data).to_bytes(2, "big"))
    s.sendall(header + b"\0\0\0\0" + data)


def read_text(s, rest=b""):
    buf = rest
    while True:
        while len(buf) < 2:
            chunk = s.recv(65536)
            if not chunk:
                return None
            buf += chunk
        op, n, at = buf[0] & 15, buf[1] & 127, 2
        if n >= 126:
            k = 2 if n == 126 else 8
            while len(buf) < 2 + k:
                chunk = s.recv(65536)
                if not chunk:
                    return None
                buf += chunk
            n, at = int.from_bytes(buf[2:2 + k], "big"), 2 + k
        while len(buf) < at + n:
            chunk = s.recv(65536)
            if not chunk:
                return None
            buf += chunk
        payload, buf = buf[at:at + n], buf[at + n:]
        if op == 8:
            return None
        if op == 1:
            return payload.decode(errors="replace")


def fd_count(pid):
    return len(os.listdir(f"/proc/{pid}/fd"))


def probe_origin():
    srv = Server(["--http", "127.0.0.1:0"], name="origin")
    origin = "http://x\nrtpm-server: client 1 (admin) joined\x1b[2J" + "A" * 8000
    start, sent = time.time(), 0
    while time.time() - start < 5:
        try:
            s = connect(srv.http)
            upgrade(s, origin)
            s.close()
            sent += 1
        except OSError:
            pass
    seconds = time.time() - start
    srv.stop()
    err = srv.err()  # with the summary lines written at the end
    lines, forged, esc = err.count(b"\n"), err.count(b"\nrtpm-server: client 1"), err.count(b"\x1b")
    say("origin", f"{sent} upgrades with 8 kB Origins in {seconds:.1f} s: stderr grew {len(err) / seconds / 1e6:.3f} MB/s, "
                  f"{lines} lines, forged lines (raw line feed): {forged}, raw ESC bytes: {esc}")


def probe_fds():
    srv = Server(["--http", "127.0.0.1:0"], name="fds")
    base = fd_count(srv.proc.pid)
    held, peak, done = [], [0], [False]
    lock = threading.Lock()

    def sample():
        while not done[0]:
            try:
                peak[0] = max(peak[0], fd_count(srv.proc.pid) - base)
            except OSError:
                pass
            time.sleep(0.02)

    def flood(a):
        for _ in range(100):
            try:
                s = connect(srv.http, f"127.0.2.{a + 2}")
                with lock:
                    held.append(s)
            except OSError:
                pass
    sampler = threading.Thread(target=sample)
    sampler.start()
    start = time.time()
    threads = [threading.Thread(target=flood, args=(a,)) for a in range(10)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    connected = time.time() - start
    time.sleep(7)
    later = fd_count(srv.proc.pid) - base
    done[0] = True
    sampler.join()
    for s in held:
        s.close()
    srv.stop()
    say("fds", f"1000 idle HTTP connections from 10 addresses (connected in {connected:.1f} s): the master held at most "
               f"{peak[0]} descriptors for them, {later} 7 s later (baseline {base})")


def probe_guesses():
    srv = Server(["--http", "127.0.0.1:0"], name="guesses")
    wrong = refused = 0
    lock = threading.Lock()
    stop = time.time() + 5

    def worker(i):
        nonlocal wrong, refused
        n = 0
        while time.time() < stop:
            n += 1
            try:
                s = connect(srv.http, "127.0.3.2")
                status, rest = upgrade(s)
                if status != 101:
                    with lock:
                        refused += 1
                    s.close()
                    continue
                send_text(s, '{"type":"hello","token":"guess%d-%d-000000000000000"}' % (i, n))
                reply = read_text(s, rest) or ""
                s.close()
                with lock:
                    if "wrong" in reply:
                        wrong += 1
                    else:
                        refused += 1
            except OSError:
                with lock:
                    refused += 1
    threads = [threading.Thread(target=worker, args=(i,)) for i in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    time.sleep(0.2)
    srv.stop()
    err = srv.err().decode(errors="replace")
    logged = [l for l in err.splitlines() if "failed" in l]
    say("guesses", f"one address, 8 connections at a time for 5 s: {wrong / 5:.0f} wrong tokens evaluated a second, "
                   f"{refused} attempts refused unevaluated; log lines naming failures: {len(logged)}"
                   + (f" ({logged[-1][:160]})" if logged else ""))


def probe_tokenless():
    srv = Server(["--http", "127.0.0.1:0", "--max-viewers", "8"], name="tokenless")
    silent = []
    for a in range(8):
        s = connect(srv.http, f"127.0.4.{a + 2}", timeout=40)
        status, _ = upgrade(s)
        silent.append(s)
    real = connect(srv.http, "127.0.4.100")
    status, rest = upgrade(real)
    answer = f"HTTP {status}"
    if status == 101:
        send_text(real, '{"type":"hello","token":"%s"}' % TOKEN)
        answer = (read_text(real, rest) or "closed")[:40]
    start = time.time()
    closed = 0
    for s in silent:
        try:
            s.settimeout(max(0.1, 30 - (time.time() - start)))
            if not s.recv(1 << 16):
                closed += 1
        except OSError:
            pass
    waited = time.time() - start
    srv.stop()
    say("tokenless", f"8 WebSockets without a hello, --max-viewers 8: a real viewer got {answer!r}; "
                     f"{closed} of 8 silent ones closed within {waited:.1f} s")


def probe_insecure():
    for flags in (["--insecure-no-token"], ["--viewer-token", "x"], ["--viewer-token", "abcdefghijklmnop"],
                  ["--viewer-token", "0123456789abcdef"]):
        srv = Server(["--http", "127.0.0.1:0"] + flags, env_token=flags[0] != "--insecure-no-token",
                     name="insecure")
        time.sleep(0.3)
        running = srv.proc.poll() is None
        code = srv.stop()
        first = srv.err().decode(errors="replace").strip().splitlines()
        say("insecure", f"--http {' '.join(flags)}: " + ("started (serving)" if running else
                                                         f"refused, exit {code}: {first[0][:150] if first else ''}"))


def probe_rebinding():
    srv = Server(["--http", "127.0.0.1:0"], name="rebinding")
    p = srv.http
    results = []
    for origin, host in ((f"http://evil.example:{p}", f"evil.example:{p}"), (f"http://127.0.0.1:{p}", f"127.0.0.1:{p}")):
        s = connect(p)
        status, _ = upgrade(s, origin, host)
        s.close()
        results.append(f"Origin {origin} with Host {host}: {status}")
    srv.stop()
    say("rebinding", "; ".join(results))


def probe_nodes():
    path = os.path.join(WORK, "million.gltf")
    with open(path, "w") as f:
        f.write('{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],'
                '"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],'
                '"buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,'
                'AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],'
                '"bufferViews":[{"buffer":0,"byteLength":36}],'
                '"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",'
                '"min":[0,0,0],"max":[1,1,0]}],"nodes":[{"children":[' +
                ",".join(str(i) for i in range(1, 1000001)) + "]}")
        for i in range(1000000):
            f.write(',{"mesh":0,"translation":[%d,0,0]}' % (i % 1000))
        f.write("]}")
    size = os.path.getsize(path)
    start = time.time()
    err_path = os.path.join(WORK, "nodes.err")
    proc = subprocess.Popen([SERVER, "--port", "0", "--scene", path, "--frames", "1", "--width", "16", "--height", "12",
                             "--out", os.path.join(WORK, "nodes.exr")], env=dict(os.environ, RTPM_TOKEN=TOKEN),
                            stdout=subprocess.PIPE, stderr=open(err_path, "wb"))
    # Until it listens (the scene loaded and encoded for clients) or refuses the scene.
    line = proc.stdout.readline().decode(errors="replace")
    peak = 0
    try:
        for l in open(f"/proc/{proc.pid}/status"):
            if l.startswith("VmHWM:"):
                peak = int(l.split()[1]) // 1024
    except OSError:
        pass
    seconds = time.time() - start
    proc.kill()
    proc.wait()
    err = open(err_path, "rb").read().decode(errors="replace").strip().splitlines()
    outcome = f"listening after {seconds:.1f} s, peak RSS {peak} MiB" if "listening" in line else \
        f"refused after {seconds:.1f} s (exit {proc.returncode}): {err[0][:200] if err else ''}"
    say("nodes", f"a glTF of a million nodes ({size / 1e6:.0f} MB), one triangle instanced by each: {outcome}")


def frames_in_20_s(flood):
    """Frames the master shows in 20 s with one client, beside `flood(port, stopped)` if given."""
    srv = Server(["--min-clients", "1"], name="nat", frames="0", size=("32", "24"))
    stopped = threading.Event()
    t = threading.Thread(target=flood, args=(srv.port, stopped)) if flood else None
    if t:
        t.start()
    time.sleep(2)
    client = subprocess.Popen([CLIENT, "--server", f"127.0.0.1:{srv.port}", "--token", TOKEN, "--threads", "1",
                               "--connect-timeout", "60"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(20)
    stopped.set()
    if t:
        t.join()
    srv.stop()
    client.wait(30)
    out = open(srv.out_path, "rb").read().decode(errors="replace")
    return len(re.findall(r"^frame ", out, re.M)), "joined" in srv.err().decode(errors="replace")


def probe_nat():
    # A real client and an idle flood share 127.0.0.1 (NAT): the flood keeps 32 idle sockets open,
    # reconnecting, while the client joins and renders. The same run without the flood first: the
    # frame rate depends on the machine and the frame budget, so only the ratio is a figure.
    def flood(port, stopped):
        idle = []
        while not stopped.is_set():
            try:
                idle.append(connect(port, "127.0.0.1"))
            except OSError:
                time.sleep(0.01)
            if len(idle) > 32:
                idle.pop(0).close()
            time.sleep(0.002)
        for s in idle:
            s.close()
    alone, _ = frames_in_20_s(None)
    frames, joined = frames_in_20_s(flood)
    say("nat", f"idle flood of 32 sockets from the client's own address: {frames} frames shown in 20 s, "
               f"{alone} without the flood ({'the client joined' if joined else 'the client never joined'})")


PROBES = {"origin": probe_origin, "fds": probe_fds, "guesses": probe_guesses, "tokenless": probe_tokenless,
          "insecure": probe_insecure, "rebinding": probe_rebinding, "nodes": probe_nodes, "nat": probe_nat}

if __name__ == "__main__":
    unknown = [name for name in sys.argv[2:] if name not in PROBES]
    if unknown:
        sys.exit(f"viewer_port_probe.py: unknown probe {' '.join(unknown)} (probes: {' '.join(PROBES)})")
    for name in sys.argv[2:] or PROBES:
        PROBES[name]()
