"""Line-in → line-out latency of `tolles stream --derivative causal` with and without `--live`
and a browser connected to it (issue 60: within 10 %). `bench/stream_live` calls this.

A simulated box at 200 Hz is fed at 1280 lines/s for SECONDS (default 20) through a pipe; a
reader thread stamps each output line. Three runs: no page; `--live` with no browser; `--live`
with one client on the server-sent events and one polling /state.json every 250 ms. Prints the
p50, p99 and max of each (µs)."""

import argparse
import io
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def run(tolles, model, lines, rate, live, browser):
    args = [tolles, "stream", "--model", model, "--derivative", "causal", "--quiet"]
    if live:
        args += ["--live", "127.0.0.1:0", "--live-linger", "0"]
    p = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         bufsize=0)
    clients = []
    if live:
        said = p.stderr.readline().decode()
        address = said.strip().split("http://")[1].rstrip("/")
        if browser:
            events = subprocess.Popen(["curl", "-sN", f"http://{address}/events"],
                                      stdout=subprocess.DEVNULL)
            clients.append(events)
            stop = threading.Event()

            def poll():
                while not stop.is_set():
                    try:
                        urllib.request.urlopen(f"http://{address}/state.json", timeout=2).read()
                    except OSError:
                        pass
                    time.sleep(0.25)
            poller = threading.Thread(target=poll, daemon=True)
            poller.start()
            clients.append(stop)
    sent, got = [], []

    out = io.BufferedReader(p.stdout, buffer_size=1 << 16)

    def read():
        out.readline()  # header
        for _ in lines[1:]:
            out.readline()
            got.append(time.perf_counter())
    reader = threading.Thread(target=read)
    reader.start()
    p.stdin.write(lines[0])
    start = time.perf_counter()
    for k, line in enumerate(lines[1:]):
        # Sleeping, not spinning: a spinning feeder holds the GIL from the reader thread.
        wait = start + k / rate - time.perf_counter()
        if wait > 0:
            time.sleep(wait)
        sent.append(time.perf_counter())
        p.stdin.write(line)
    reader.join()
    p.stdin.close()
    p.wait()
    for c in clients:
        if isinstance(c, threading.Event):
            c.set()
        else:
            c.kill()
    latency = sorted((g - s) * 1e6 for s, g in zip(sent, got))
    q = lambda f: latency[min(len(latency) - 1, int(f * len(latency)))]  # noqa: E731
    return q(0.5), q(0.99), latency[-1]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tolles", default=str(ROOT / "target" / "release" / "tolles"))
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--rate", type=float, default=1280.0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        box, model = f"{tmp}/box.csv", f"{tmp}/m.json"
        subprocess.run([args.tolles, "simulate", "--plan", "box", "--fs", "200", "--out", box],
                       check=True, capture_output=True)
        subprocess.run([args.tolles, "fit", box, "--scalar", "mag_1_uc", "--vector", "flux_a",
                        "--out", model], check=True, capture_output=True)
        lines = Path(box).read_bytes().splitlines(keepends=True)
        lines = lines[: 1 + int(args.seconds * args.rate)]
        print(f"{len(lines) - 1} lines at {args.rate:g} lines/s, --derivative causal")
        print("| run | p50 (µs) | p99 (µs) | max (µs) |\n|---|---|---|---|")
        for name, live, browser in [("no page", False, False), ("--live, no browser", True, False),
                                    ("--live, events + polling client", True, True)]:
            p50, p99, worst = run(args.tolles, model, lines, args.rate, live, browser)
            print(f"| {name} | {p50:.0f} | {p99:.0f} | {worst:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
