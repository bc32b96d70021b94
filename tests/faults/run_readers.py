#!/usr/bin/env python3
"""Readers beside a running mapper (issue 21).

`diskchungs run` maps a synthetic street that checkpoints every few keyframes while reader
processes run `export` (twice) and `render` on the same folder, one after another (under `nice`),
until the run ends (at least --reads of them while it runs: choose --length to suit). The rule
(README, "Readers may run beside a running mapper"): a reader reads the last committed checkpoint
whole, starting over by itself when the mapper's commits take files before it has them open.
A watcher notes, as each checkpoint's manifest appears, the Gaussians export would write from it. Every read is judged:

  ok        export wrote exactly the Gaussians of one committed checkpoint, or render wrote every
            view (a handful along the street) as a whole PNG
  refused   "not a map folder" or (render) "no keyframes.txt": the run had not committed its first
            checkpoint when the read began
  unseen    export wrote a count that no checkpoint the watcher saw had, while the watcher missed a
            checkpoint the read may have taken (one replaced within the watcher's polling, on a loaded
            machine): it cannot be judged; more than a fifth of the exports so is a failure
  bad       anything else: a crash, a hang (10 s), an error (also "the map changed faster than it
            could be read"), a count that no committed checkpoint had, a missing or torn PNG

Reads that started over (a line "committed again while") are counted as retries. Then the
mapper's FPS with readers is compared with a run without them, made just before in the same
script run. Exit status 1 when a read was bad, the mapper failed, fewer than --reads reads ended
during the run, or FPS dropped more than --max-drop.
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import zlib
from pathlib import Path

sys.dont_write_bytecode = True
sys.path.insert(0, str(Path(__file__).resolve().parent))

from map_checks import exported_total, ply_count, read_manifest  # noqa: E402

CONFIG = """mapper:
  checkpoint_every: 3
  checkpoint_max_share: 0
  keyframe_every: 1
"""
REFUSALS = ("not a map folder", "no keyframes.txt")
RETRY = "committed again while"
CRASH_MARKERS = ("terminate called", "Segmentation fault", "Aborted", "core dumped", "runtime error:")
FPS = re.compile(r"([0-9.]+) FPS")


def whole_png(path):
    """A PNG whose every chunk is there with a matching CRC, ending in IEND (not a torn write)."""
    data = Path(path).read_bytes()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        return False
    pos = 8
    while pos + 12 <= len(data):
        n = int.from_bytes(data[pos:pos + 4], "big")
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        if len(body) != n or pos + 12 + n > len(data):
            return False
        if zlib.crc32(kind + body) != int.from_bytes(data[pos + 8 + n:pos + 12 + n], "big"):
            return False
        pos += 12 + n
        if kind == b"IEND":
            return pos == len(data)
    return False


class Watcher:
    """What export would write from every checkpoint, read as its manifest is renamed into place (a manifest is
    replaced whole, so a read gets one; a checkpoint replaced before the watcher saw it is a gap)."""

    def __init__(self, folder):
        self.folder, self.totals, self.stop = folder, {}, threading.Event()

    def loop(self):
        os.nice(19)  # this thread only (Linux): the watcher, like the readers, takes what the mapper leaves
        last = None
        while not self.stop.is_set():
            try:
                st = os.stat(self.folder / "manifest.txt")
                key = (st.st_ino, st.st_mtime_ns)
                if key != last:
                    checkpoint, chunks, _ = read_manifest(self.folder / "manifest.txt")
                    self.totals[checkpoint] = exported_total(chunks)
                    last = key
            except (OSError, ValueError, IndexError):
                pass
            time.sleep(0.01)

    def gaps(self):
        seen = sorted(k for k in self.totals if k > 0)
        return [k for k in range(seen[0], seen[-1] + 1) if k not in self.totals] if seen else []


class Readers:
    def __init__(self, cli, folder, poses, work, pause, watcher):
        self.cli, self.folder, self.poses, self.work, self.pause = cli, folder, poses, work, pause
        self.watcher = watcher
        self.counts = {"ok": 0, "refused": 0, "unseen": 0, "bad": 0}
        self.retries = 0  # reads that started over from a newer checkpoint
        self.during = 0  # reads that ended while the mapper was still running
        self.seen = set()  # checkpoints that successful exports matched
        self.exports = 0
        self.views = sum(1 for line in open(poses) if line.strip() and not line.startswith("#"))
        self.stride = max(1, self.views // 4)  # a handful of views along the whole street
        self.bad = []
        self.stop = threading.Event()

    def one(self, n):
        # Two exports to a render: a render costs several times an export, and the CPU a reader
        # takes on 2 cores is what the mapper loses (info, which reads no map, is no read of one).
        kind = ("export", "export", "render")[n % 3]
        renders = self.work / "renders"
        if kind == "export":
            self.exports += 1
            (self.work / "r.ply").unlink(missing_ok=True)
            args = ["export", "--map", str(self.folder), "--out", str(self.work / "r.ply")]
        else:
            shutil.rmtree(renders, ignore_errors=True)
            args = ["render", "--map", str(self.folder), "--poses", str(self.poses), "--stride", str(self.stride),
                    "--out", str(renders)]
        committed_before = any(k > 0 for k in list(self.watcher.totals))
        latest_before = max(self.watcher.totals, default=0)
        try:
            p = subprocess.run(["nice", "-n", "19", self.cli] + args, capture_output=True, text=True, timeout=10)
        except subprocess.TimeoutExpired:
            return "bad", f"{kind}: hang"
        err = p.stderr
        self.retries += err.count(RETRY)
        if p.returncode < 0 or any(m in err for m in CRASH_MARKERS):
            return "bad", f"{kind}: crash ({p.returncode}) {err[-200:]}"
        if p.returncode != 0:
            lines = [l for l in err.splitlines() if l.strip() and RETRY not in l]
            if len(lines) == 1 and any(r in lines[0] for r in REFUSALS) and not committed_before:
                return "refused", ""
            return "bad", f"{kind}: exit {p.returncode}: {err.strip()[-200:]}"
        if kind == "export":
            got = ply_count(self.work / "r.ply")
            # The checkpoint the export read was committed before it ended, but the niced watcher may
            # not have read its manifest yet on a loaded machine: give it a few seconds to catch up.
            deadline = time.time() + 5
            while True:
                match = [k for k, t in list(self.watcher.totals.items()) if t == got]
                if match or time.time() > deadline:
                    break
                time.sleep(0.02)
            if not match:
                # The read took the checkpoint committed when it began or a newer one: if the watcher
                # missed one of those, the count cannot be checked against it.
                if any(k >= latest_before for k in self.watcher.gaps()):
                    return "unseen", ""
                return "bad", f"export wrote {got} Gaussians, no committed checkpoint had that many"
            self.seen.add(max(match))
        elif kind == "render":
            pngs = sorted(renders.glob("*.png"))
            want = (self.views + self.stride - 1) // self.stride
            if len(pngs) != want or not all(whole_png(f) for f in pngs):
                return "bad", f"render wrote {len(pngs)} PNGs ({want} expected) or a torn one"
        return "ok", ""

    def loop(self):
        os.nice(19)  # the checks of each read too, not only the reader processes
        n = 0
        while not self.stop.is_set():
            verdict, detail = self.one(n)
            self.counts[verdict] += 1
            self.during += not self.stop.is_set()
            if detail:
                self.bad.append(detail)
            n += 1
            time.sleep(self.pause)


def run_mapper(cli, dataset, folder, config, threads, device):
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    cmd = [cli, "run", "--dataset", dataset, "--poses", "gt", "--device", device, "--iterations", "3",
           "--final-iterations", "0", "--no-eval", "--out", str(folder), "--config", str(config)]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)


def finish(p, what):
    out, err = p.communicate(timeout=1800)
    m = FPS.search(out + err)
    if p.returncode != 0 or not m:
        sys.exit(f"{what}: the mapper failed ({p.returncode}): {err.strip()[-400:]}")
    return float(m.group(1))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cli", required=True)
    ap.add_argument("--length", type=int, default=400, help="street length in metres (frames)")
    ap.add_argument("--reads", type=int, default=1000, help="reads at least while the mapper runs")
    ap.add_argument("--pause", type=float, default=0.02, help="seconds between reads")
    ap.add_argument("--threads", type=int, default=2, help="the mapper's OMP_NUM_THREADS")
    ap.add_argument("--max-drop", type=float, default=0.10, help="allowed FPS loss with readers")
    ap.add_argument("--device", default="cpu", help="the mapper's --device (cpu, cuda)")
    args = ap.parse_args()
    cli = str(Path(args.cli).resolve())
    dataset = f"synth-street:length={args.length},width=160,height=48"
    with tempfile.TemporaryDirectory(prefix="chungs-readers-") as tmp:
        work = Path(tmp)
        config = work / "config.yaml"
        config.write_text(CONFIG)
        alone = run_mapper(cli, dataset, work / "alone", config, args.threads, args.device)
        fps_alone = finish(alone, "without readers")
        poses = work / "poses.txt"
        shutil.copy(work / "alone" / "trajectory.txt", poses)
        watcher = Watcher(work / "map")
        # The readers' PLY and PNGs go to memory where there is some: written to the disk they would
        # compete with the mapper's flushes, which is not what reading the map costs it.
        shm = Path("/dev/shm")
        out = Path(tempfile.mkdtemp(prefix="chungs-readers-", dir=shm if shm.is_dir() else work))
        readers = Readers(cli, work / "map", poses, out, args.pause, watcher)
        start = time.time()
        w = threading.Thread(target=watcher.loop)
        w.start()
        mapper = run_mapper(cli, dataset, work / "map", config, args.threads, args.device)
        t = threading.Thread(target=readers.loop)
        t.start()
        fps_readers = finish(mapper, "with readers")
        readers.stop.set()
        t.join()
        # Once the run has ended every read gets the finished map.
        after = [readers.one(n) for n in range(6)]
        watcher.stop.set()
        w.join()
        for verdict, detail in after:
            readers.counts[verdict] += 1
            if verdict != "ok":
                readers.bad.append(f"after the run: {verdict} {detail}")
                readers.counts["bad"] += verdict in ("refused", "unseen")
        seconds = time.time() - start
        reads = sum(readers.counts.values())
        checkpoints = read_manifest(work / "map" / "manifest.txt")[0]
        print(f"{reads} reads in {seconds:.0f} s, {readers.during} of them during a run of {checkpoints} "
              "checkpoints: " + ", ".join(f"{k} {v}" for k, v in readers.counts.items())
              + f"; {readers.retries} started over from a newer checkpoint")
        print(f"exports read {len(readers.seen)} different checkpoints; the watcher saw {len(watcher.totals)}"
              f" (missed {len(watcher.gaps())})")
        for b in readers.bad[:10]:
            print("  bad:", b)
        ratio = fps_readers / fps_alone
        print(f"mapper FPS: {fps_alone:.2f} alone, {fps_readers:.2f} with readers ({ratio:.3f})")
        shutil.rmtree(out, ignore_errors=True)
    failed = (readers.counts["bad"] > 0 or 5 * readers.counts["unseen"] > readers.exports or readers.during < args.reads
              or ratio < 1 - args.max_drop)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
