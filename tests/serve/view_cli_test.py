#!/usr/bin/env python3
"""`diskchungs view` as a user runs it (issue 24): flags out of range and a missing map are refused by
name, the URL is printed, a second server on the same port fails naming host:port, the API answers,
Ctrl-C (SIGINT) ends it with status 0, and the map folder is byte for byte what it was. Then
`run --view`: a bad port refused before mapping, checkpoints served while the run goes on, the
server gone when the run ends.
    python3 view_cli_test.py --cli DISKCHUNGS"""
import argparse
import hashlib
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

ap = argparse.ArgumentParser()
ap.add_argument("--cli", required=True)
args = ap.parse_args()
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        failures.append(what)


def run(*a, timeout=120):
    return subprocess.run([args.cli, *a], capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, "OMP_NUM_THREADS": "2"})


def digest(folder):
    h = {}
    for root, _, files in os.walk(folder):
        for f in files:
            p = os.path.join(root, f)
            with open(p, "rb") as fh:
                h[os.path.relpath(p, folder)] = hashlib.sha256(fh.read()).hexdigest()
    return h


def start_view(*extra):
    p = subprocess.Popen([args.cli, "view", *extra], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    line = p.stdout.readline()
    m = re.search(r"at (http://\S+/)", line)
    return p, (m.group(1) if m else None), line


with tempfile.TemporaryDirectory() as tmp:
    room, m = os.path.join(tmp, "room"), os.path.join(tmp, "map")
    r = run("-q", "synth", "room", "--out", room, "--frames", "6", "--width", "64", "--height", "48")
    assert r.returncode == 0, r.stdout + r.stderr
    r = run("-q", "run", "--dataset", "tum:" + room, "--device", "cpu", "--out", m, "--no-eval", "--iterations", "5",
            "--final-iterations", "5", "--chunk-size", "1")
    assert r.returncode == 0, r.stdout + r.stderr
    before = digest(m)

    for bad in ["-1", "65536", "80x"]:
        r = run("view", m, "--port", bad, timeout=20)
        check(r.returncode != 0 and "--port" in r.stderr, f"--port {bad} refused naming the flag: {r.stderr.strip()}")
    r = run("view", os.path.join(tmp, "nothing"), "--port", "0", timeout=20)
    check(r.returncode != 0 and "nothing" in r.stderr, f"a missing map refused by name: {r.stderr.strip()}")

    first, url, line = start_view(m, "--port", "0")
    check(url is not None, f"the URL printed on start: {line.strip()}")
    if url:
        port = url.rsplit(":", 1)[1].strip("/")
        second = run("view", m, "--port", port, timeout=20)
        check(second.returncode != 0 and f"127.0.0.1:{port}" in second.stderr and "in use" in second.stderr,
              f"a taken port refused naming host:port: {second.stderr.strip()}")
        with urllib.request.urlopen(url + "api/map", timeout=10) as resp:
            info = json.load(resp)
        check(len(info["chunks"]) > 0 and info["total_gaussians"] > 0,
              f"/api/map answers: {len(info['chunks'])} chunks, {info['total_gaussians']} Gaussians")
    t0 = time.time()
    first.send_signal(signal.SIGINT)
    try:
        rest = first.communicate(timeout=10)[0]
        check(first.returncode == 0 and "stopped" in rest,
              f"Ctrl-C stops it cleanly in {time.time() - t0:.2f} s (status {first.returncode})")
    except subprocess.TimeoutExpired:
        first.kill()
        check(False, "Ctrl-C stops it within 10 s")
    check(digest(m) == before, "the map folder is unchanged")

    # run --view: the viewer beside the mapper in one process, from the first checkpoint to the end.
    r = run("run", "--dataset", "tum:" + room, "--out", os.path.join(tmp, "never"), "--view", "70000", timeout=20)
    check(r.returncode != 0 and "--view" in r.stderr and not os.path.exists(os.path.join(tmp, "never")),
          f"run --view 70000 refused before mapping: {r.stderr.strip()}")
    cfg = os.path.join(tmp, "every.yaml")
    with open(cfg, "w") as f:
        # Every frame a keyframe and a checkpoint, each keyframe long enough (300 steps) that the poller
        # sees several of them even on a loaded machine.
        f.write("mapper:\n  checkpoint_every: 1\n  checkpoint_seconds: 0\n  checkpoint_max_share: 0\n"
                "  keyframe_every: 1\n")
    live = os.path.join(tmp, "live")
    p = subprocess.Popen([args.cli, "-q", "run", "--dataset", "tum:" + room, "--device", "cpu", "--out", live,
                          "--no-eval", "--iterations", "300", "--final-iterations", "0", "--chunk-size", "1",
                          "--config", cfg, "--view", "0"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                         env={**os.environ, "OMP_NUM_THREADS": "2"})
    line = p.stdout.readline()
    m = re.search(r"viewer at (http://\S+/)", line)
    check(m is not None, f"run --view prints the viewer's URL: {line.strip()}")
    seen = set()
    while m and p.poll() is None:
        try:
            with urllib.request.urlopen(m.group(1) + "api/map", timeout=5) as resp:
                seen.add(json.load(resp)["checkpoint"])
        except urllib.error.HTTPError as e:
            seen.add("503" if e.code == 503 else e.code)
        except (urllib.error.URLError, ConnectionError):
            break  # the run ended between poll() and the request
        time.sleep(0.05)
    rest = p.communicate(timeout=120)[0]
    numbers = sorted(c for c in seen if isinstance(c, int))
    check(p.returncode == 0 and len(numbers) >= 2,
          f"run --view served the checkpoints as they came: {numbers} (and {seen - set(numbers) or 'no'} errors); exit {p.returncode}")
    if m:
        try:
            urllib.request.urlopen(m.group(1) + "api/map", timeout=5)
            check(False, "the viewer stops with the run")
        except (urllib.error.URLError, ConnectionError):
            check(True, "the viewer stops with the run")

print("view_cli_test: " + ("passed" if not failures else "FAILED: " + "; ".join(failures)))
sys.exit(1 if failures else 0)
