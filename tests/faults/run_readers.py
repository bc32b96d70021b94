#!/usr/bin/env python3
"""Readers beside a running mapper (issue 21).

`diskchungs run` maps a synthetic street that checkpoints every few keyframes while reader
processes run `export`, `render` and `info` on the same folder, one after another, until the run
ends (at least --reads of them while it runs: choose --length to suit). The rule (README, "Readers and a running mapper"): a writer holds
the folder's lock for the whole run, so a reader either reads one committed checkpoint whole or is
refused at once with "map folder is being written" (or "not a map folder" before the first commit).
Every read is judged:

  ok        export wrote exactly the Gaussians of the manifest it read (the same manifest before
            and after), or render drew its views, or info answered; a map read that succeeds must
            find the run's last checkpoint (it got in after the run let go of the folder)
  refused   the lock or no manifest yet: exit 1 with that one error line
  bad       anything else: a crash, a hang (10 s), another error, a count that matches no
            committed manifest

Then the mapper's FPS with readers is compared with a run without them (the readers run under
`nice -n 19` with a pause of --pause seconds between reads, so that on 2 cores they take the CPU
the mapper leaves). Exit status 1 when a read was bad, the mapper failed, or FPS dropped more than
--max-drop.
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
from pathlib import Path

sys.dont_write_bytecode = True
sys.path.insert(0, str(Path(__file__).resolve().parent))

from map_checks import ply_count, read_manifest  # noqa: E402

CONFIG = """mapper:
  checkpoint_every: 3
  checkpoint_max_share: 0
  keyframe_every: 1
"""
REFUSALS = ("map folder is being written", "not a map folder")
CRASH_MARKERS = ("terminate called", "Segmentation fault", "Aborted", "core dumped", "runtime error:")
FPS = re.compile(r"([0-9.]+) FPS")


def manifest_total(folder):
    try:
        return sum(c[0] for c in read_manifest(folder / "manifest.txt")[1].values())
    except (OSError, ValueError, IndexError):
        return None


class Readers:
    def __init__(self, cli, folder, poses, work, pause):
        self.cli, self.folder, self.poses, self.work, self.pause = cli, folder, poses, work, pause
        self.counts = {"ok": 0, "refused": 0, "bad": 0}
        self.during = 0  # reads that ended while the mapper was still running
        self.seen = set()  # checkpoints that successful reads found committed
        self.bad = []
        self.stop = threading.Event()

    def one(self, n):
        kind = ("export", "render", "info")[n % 3]
        if kind == "export":
            args = ["export", "--map", str(self.folder), "--out", str(self.work / "r.ply")]
        elif kind == "render":
            args = ["render", "--map", str(self.folder), "--poses", str(self.poses), "--stride", "50",
                    "--out", str(self.work / "renders"), "-q"]
        else:
            args = ["info"]
        before = manifest_total(self.folder)
        try:
            p = subprocess.run(["nice", "-n", "19", self.cli] + args, capture_output=True, text=True, timeout=10)
        except subprocess.TimeoutExpired:
            return "bad", f"{kind}: hang"
        after = manifest_total(self.folder)
        err = p.stderr
        if p.returncode < 0 or any(m in err for m in CRASH_MARKERS):
            return "bad", f"{kind}: crash ({p.returncode}) {err[-200:]}"
        if p.returncode != 0:
            lines = [l for l in err.splitlines() if l.strip()]
            if len(lines) == 1 and any(r in lines[0] for r in REFUSALS):
                return "refused", ""
            return "bad", f"{kind}: exit {p.returncode}: {err.strip()[-200:]}"
        if kind == "export":
            got = ply_count(self.work / "r.ply")
            if before == after and got != before:
                return "bad", f"export wrote {got} Gaussians, the manifest lists {before}"
        if kind != "info":  # info reads no map: it shows only that the CLI stays responsive
            self.seen.add(read_manifest(self.folder / "manifest.txt")[0])
        return "ok", ""

    def loop(self):
        n = 0
        while not self.stop.is_set():
            verdict, detail = self.one(n)
            self.counts[verdict] += 1
            self.during += not self.stop.is_set()
            if detail:
                self.bad.append(detail)
            n += 1
            time.sleep(self.pause)


def run_mapper(cli, dataset, folder, config, threads):
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    cmd = [cli, "run", "--dataset", dataset, "--poses", "gt", "--device", "cpu", "--iterations", "3",
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
    args = ap.parse_args()
    cli = str(Path(args.cli).resolve())
    dataset = f"synth-street:length={args.length},width=160,height=48"
    with tempfile.TemporaryDirectory(prefix="chungs-readers-") as tmp:
        work = Path(tmp)
        config = work / "config.yaml"
        config.write_text(CONFIG)
        alone = run_mapper(cli, dataset, work / "alone", config, args.threads)
        fps_alone = finish(alone, "without readers")
        poses = work / "poses.txt"
        shutil.copy(work / "alone" / "trajectory.txt", poses)
        readers = Readers(cli, work / "map", poses, work, args.pause)
        start = time.time()
        mapper = run_mapper(cli, dataset, work / "map", config, args.threads)
        t = threading.Thread(target=readers.loop)
        t.start()
        fps_readers = finish(mapper, "with readers")
        readers.stop.set()
        t.join()
        # Once the run has ended every read gets the finished map.
        after = [readers.one(n) for n in range(6)]
        for verdict, detail in after:
            readers.counts[verdict] += 1
            if verdict != "ok":
                readers.bad.append(f"after the run: {verdict} {detail}")
                readers.counts["bad"] += verdict == "refused"
        seconds = time.time() - start
        reads = sum(readers.counts.values())
        checkpoints = read_manifest(work / "map" / "manifest.txt")[0]
        print(f"{reads} reads in {seconds:.0f} s, {readers.during} of them during a run of {checkpoints} "
              "checkpoints: " + ", ".join(f"{k} {v}" for k, v in readers.counts.items()))
        print(f"successful map reads found checkpoint {sorted(readers.seen)}, the run's last is {checkpoints}")
        for b in readers.bad[:10]:
            print("  bad:", b)
        ratio = fps_readers / fps_alone
        print(f"mapper FPS: {fps_alone:.2f} alone, {fps_readers:.2f} with readers ({ratio:.3f})")
    # A map read that succeeded mid-run (an earlier checkpoint) would break the rule the README states.
    mid_run = readers.seen - {checkpoints}
    failed = (readers.counts["bad"] > 0 or readers.during < args.reads or ratio < 1 - args.max_drop
              or bool(mid_run))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
