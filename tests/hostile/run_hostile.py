#!/usr/bin/env python3
"""Hostile-input runner for the diskchungs CLI (issue 21).

Builds small valid seeds with the CLI, damages a copy of one per case (or types a bad value on the
command line), runs the CLI as a user would and classifies the outcome:

  pass      the expected outcome: an error whose message names the file, flag or value at fault
            (every case lists the words it must contain), or success for valid input
  crash     killed by a signal, exit status >= 128, or an abort / sanitizer report on stderr
  hang      still running after the time limit (the process group is killed)
  memory    peak RSS above 1 GB, or an allocation failure (std::bad_alloc), from inputs under 1 MB
  changed   a dataset folder's files (names and contents) differ afterwards, or a map folder's after
            a reader (export, render, inspect, eval, track) or after any command that failed
  accepted  exit status 0 where an error was expected: an invalid value accepted silently
  refused   non-zero exit for input that is valid
  unclear   an error, but the message lacks a word naming what is at fault (or, where a writer may
            repair the damage and go on, its warning does not name what it dropped)

One line per case (name, verdict, exit status, peak RSS, seconds), then counts per verdict. Exit
status 1 when any case failed. ctest runs every case; `--quick` runs about 45 of them, one or two
per kind of input, for a look in seconds.

known_failures.txt lists cases that fail for a cause another change is fixing, each with the one
verdict it fails with: such a case counts as `known`, not as a failure, as long as that verdict is
its only problem. A listed case that passes, or fails otherwise, fails the run, so the list can only
shrink; an entry naming no case is refused.
"""

import argparse
import concurrent.futures
import hashlib
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, str(Path(__file__).resolve().parent))

import cases as case_list  # noqa: E402
from seeds import Seeds  # noqa: E402

MEMORY_LIMIT_KB = 1024 * 1024  # 1 GB of peak RSS
SMALL_INPUT = 1 << 20  # the memory verdict applies to inputs below 1 MB
# Address-space cap for each run: a memory bomb that slips through fails an allocation here instead
# of taking the machine, which other jobs share (the RSS and bad_alloc checks still see it).
ADDRESS_SPACE_LIMIT = 6 << 30
CRASH_MARKERS = ("terminate called", "Segmentation fault", "Aborted", "AddressSanitizer", "LeakSanitizer",
                 "runtime error:", "Assertion `", "stack smashing", "double free", "free(): ", "malloc(): ",
                 "core dumped")
MEMORY_MARKERS = ("bad_alloc", "out of memory", "Cannot allocate memory", "cannot allocate memory")
READERS = ("export", "render", "inspect", "eval", "info", "track")
FAILED = ("crash", "hang", "memory", "changed", "partial", "accepted", "refused", "unclear")
# Commands whose --out is one file: a failed one must leave none (a failed export once left a PLY of
# 0 Gaussians that read as a valid, empty map).
ONE_FILE_OUT = ("export",)
KNOWN_FAILURES = Path(__file__).resolve().parent / "known_failures.txt"


class Known:
    def __init__(self, name, verdict, module, reason):
        self.name, self.verdict, self.module, self.reason = name, verdict, module, reason


def read_known_failures(path: Path, names) -> dict:
    """NAME VERDICT MODULE REASON... per line (# comments); refuses malformed lines and unknown names."""
    known = {}
    for number, line in enumerate(path.read_text().splitlines(), 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        fields = line.split(None, 3)
        where = "%s:%d" % (path, number)
        if len(fields) < 4 or fields[1] not in FAILED:
            sys.exit("%s: expected NAME VERDICT MODULE REASON, VERDICT one of %s" % (where, ", ".join(FAILED)))
        if fields[0] not in names:
            sys.exit("%s: no case is named %s (take it off the list)" % (where, fields[0]))
        if fields[0] in known:
            sys.exit("%s: %s is listed twice" % (where, fields[0]))
        known[fields[0]] = Known(*fields)
    return known


def folder_digest(root: Path) -> str:
    """Names, kinds and contents of everything under root (FIFOs and devices by kind only: reading
    them could block)."""
    h = hashlib.sha256()
    if not root.exists() and not root.is_symlink():
        return "absent"
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames.sort()
        for name in sorted(dirnames + filenames):
            p = Path(dirpath) / name
            rel = str(p.relative_to(root)).encode()
            if p.is_symlink():
                h.update(b"L" + rel + os.readlink(p).encode())
            elif p.is_dir():
                h.update(b"D" + rel)
            elif p.is_file():
                h.update(b"F" + rel + hashlib.sha256(p.read_bytes()).digest())
            else:
                h.update(b"S" + rel)
    return h.hexdigest()


def input_bytes(root: Path) -> int:
    total = 0
    for dirpath, _, filenames in os.walk(root):
        for name in filenames:
            p = Path(dirpath) / name
            if p.is_file() and not p.is_symlink():
                total += p.stat().st_size
    return total


class Result:
    def __init__(self, case, verdict, code, rss_kb, seconds, detail="", problems=()):
        self.case, self.verdict, self.code, self.rss_kb, self.seconds, self.detail = (
            case, verdict, code, rss_kb, seconds, detail)
        self.problems = set(problems)  # every verdict that applies, the worst being `verdict`

    def judge(self, known):
        """A failure listed in known_failures.txt with its only verdict becomes `known`; a listed case
        that passes, or fails otherwise, becomes `listed` (a failure: the list must be updated)."""
        entry = known.get(self.case.name)
        if entry is None:
            return
        if self.problems == {entry.verdict}:
            self.verdict = "known"
            self.detail = "[%s: %s] %s" % (entry.module, entry.reason, self.detail)
        else:
            found = ", ".join(sorted(self.problems)) or "pass"
            self.detail = "the known failures list it as %s, found %s: update the list%s" % (
                entry.verdict, found, " | " + self.detail if self.detail else "")
            self.verdict = "listed"

    def line(self):
        code = "-" if self.code is None else str(self.code)
        text = "%-52s %-8s exit %-4s %7.1f MB %6.2f s" % (
            self.case.name, self.verdict, code, self.rss_kb / 1024, self.seconds)
        if self.detail:
            text += "  " + self.detail
        return text


def run_process(argv, cwd: Path, timeout: float, lock_file=None):
    """Runs argv in its own session; returns (exit code or None on timeout, peak RSS KB, seconds)."""
    held = None
    if lock_file is not None:
        import fcntl
        held = open(cwd / lock_file, "a")
        fcntl.flock(held, fcntl.LOCK_EX)
    env = dict(os.environ, OMP_NUM_THREADS="2")
    with open(cwd / "stdout.txt", "wb") as out, open(cwd / "stderr.txt", "wb") as err:
        start = time.monotonic()
        p = subprocess.Popen(argv, cwd=cwd, stdout=out, stderr=err, stdin=subprocess.DEVNULL,
                             start_new_session=True, env=env)
        nap = 0.002
        while True:
            pid, status, usage = os.wait4(p.pid, os.WNOHANG)
            if pid:
                code = os.waitstatus_to_exitcode(status)
                break
            if time.monotonic() - start > timeout:
                os.killpg(p.pid, signal.SIGKILL)
                _, status, usage = os.wait4(p.pid, 0)
                code = None
                break
            time.sleep(nap)
            nap = min(nap * 2, 0.05)
        p.returncode = 0 if code is None else code  # reaped above; keeps Popen from waiting again
        seconds = time.monotonic() - start
    if held:
        held.close()
    return code, usage.ru_maxrss, seconds


def spelled(word) -> str:
    return " or ".join(map(repr, word)) if isinstance(word, tuple) else repr(word)


def said(stderr: str, word) -> bool:
    """A word of `says` is a string, or a tuple of strings any one of which will do."""
    return any(w in stderr for w in word) if isinstance(word, tuple) else word in stderr


def problems(case, code, rss_kb, small, stderr, changed, partial=None):
    """Every check that failed, most severe first, as (verdict, detail); empty for a pass."""
    if code is None:
        return [("hang", "no exit within %g s" % case.timeout)]
    found = []
    crash = next((m for m in CRASH_MARKERS if m in stderr), None)
    if code < 0 or code >= 128 or crash:
        found.append(("crash", "signal %d" % -code if code < 0 else (crash or "exit status >= 128")))
    if small and rss_kb > MEMORY_LIMIT_KB:
        found.append(("memory", "peak RSS %.0f MB" % (rss_kb / 1024)))
    elif small and any(m in stderr for m in MEMORY_MARKERS):
        found.append(("memory", "allocation failed"))
    if changed:
        found.append(("changed", "folder changed: " + ", ".join(changed)))
    if partial:
        found.append(("partial", "a failed run left its output " + partial))
    if case.expect == "error" and code == 0:
        found.append(("accepted", "exit 0; expected an error naming " + ", ".join(map(spelled, case.says))))
    if case.expect == "ok" and code != 0:
        found.append(("refused", "valid input refused"))
    # error_or_warning: a writer may repair damage and go on, but its warning must name what it dropped.
    warned = "\n".join(line for line in stderr.splitlines() if line.startswith("[warn"))
    if (case.expect == "error" and code != 0) or case.expect == "error_or_warning":
        text = warned if case.expect == "error_or_warning" and code == 0 else stderr
        missing = [w for w in case.says if not said(text, w)]
        if missing or not text.strip():
            found.append(("unclear", "message lacks " + ", ".join(map(spelled, missing))))
    return found


def last_line(text: str) -> str:
    lines = [line for line in text.splitlines() if line.strip() and not line.startswith("[info]")]
    return lines[-1][:200] if lines else ""


def run_case(case, index: int, cli: str, seeds: Seeds, work: Path, limit: float) -> Result:
    # Numbered, not named: a message quoting its path must not name the flag by way of the folder.
    d = work / ("%04d" % index)
    d.mkdir(parents=True)
    (d / "case.txt").write_text(case.name + "\n")
    case.timeout = min(case.timeout, limit)
    try:
        if case.setup:
            case.setup(d, seeds)
    except Exception as e:  # a broken case is the runner's bug: report it, never count it as a pass
        return Result(case, "setup", None, 0, 0.0, "setup failed: %r" % e)
    small = input_bytes(d) < SMALL_INPUT
    watched = [w for w in case.watch if (d / w).exists()]
    before = {w: folder_digest(d / w) for w in watched}
    argv = ["prlimit", "--as=%d" % ADDRESS_SPACE_LIMIT, "--", cli] + case.argv()
    args = case.argv()
    out = args[args.index("--out") + 1] if "--out" in args[:-1] else None
    one_file = out if out and args and args[0] in ONE_FILE_OUT and not (d / out).exists() else None
    code, rss_kb, seconds = run_process(argv, d, case.timeout, case.hold_lock)
    # Progress and info lines do not count as naming the fault: the error (or warning) must.
    stderr = "\n".join(line for line in (d / "stderr.txt").read_text(errors="replace").splitlines()
                       if not line.startswith(("[info]", "[debug]")))
    command = next((a for a in case.argv() if not a.startswith("-")), "")
    reader = command in READERS
    # A dataset is never an output; a map is one only for a writer that succeeded.
    changed = [w for w in watched
               if (w != "map" or reader or code != 0) and folder_digest(d / w) != before[w]]
    partial = one_file if one_file and code != 0 and (d / one_file).exists() else None
    found = problems(case, code, rss_kb, small, stderr, changed, partial)
    if not found:
        return Result(case, "pass", code, rss_kb, seconds)
    # The worst problem is the verdict; the others ride along so one does not hide another.
    detail = "; ".join(("%s: %s" % f) if i else f[1] for i, f in enumerate(found))
    message = last_line(stderr) or last_line((d / "stdout.txt").read_text(errors="replace"))
    if message:
        detail += " | " + message
    if case.known:
        detail = "[known: %s] %s" % (case.known, detail)
    return Result(case, found[0][0], code, rss_kb, seconds, detail, [f[0] for f in found])


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cli", default=str(Path(__file__).resolve().parents[2] / "build/apps/diskchungs/diskchungs"),
                        help="the diskchungs binary (default build/apps/diskchungs/diskchungs)")
    parser.add_argument("--quick", action="store_true", help="only the cases marked quick (the ctest subset)")
    parser.add_argument("--filter", default="", help="only cases whose name matches this regular expression")
    parser.add_argument("--jobs", type=int, default=2, help="cases run at once (default 2)")
    parser.add_argument("--timeout", type=float, default=60, help="seconds before a case counts as a hang")
    parser.add_argument("--keep", action="store_true", help="keep the work folder (printed) for a look")
    parser.add_argument("--list", action="store_true", help="list the cases and exit")
    parser.add_argument("--known", default=str(KNOWN_FAILURES),
                        help="the known failures (default tests/hostile/known_failures.txt); '' for none")
    args = parser.parse_args()

    every = case_list.all_cases()
    names = [c.name for c in every]
    if len(set(names)) != len(names):
        sys.exit("duplicate case names: %s" % sorted({n for n in names if names.count(n) > 1}))
    known = read_known_failures(Path(args.known), set(names)) if args.known else {}
    selected = [c for c in every if (c.quick or not args.quick) and re.search(args.filter, c.name)]
    if args.list:
        for c in selected:
            print("%-52s expect %-5s %s" % (c.name, c.expect, " ".join("|".join(w) if isinstance(w, tuple) else w
                                                                         for w in c.says)))
        print("%d cases" % len(selected))
        return 0
    if not os.access(args.cli, os.X_OK):
        sys.exit("no diskchungs binary at %s (build it, or pass --cli)" % args.cli)

    work = Path(tempfile.mkdtemp(prefix="diskchungs-hostile-"))
    t0 = time.monotonic()
    seeds = Seeds(work / "seeds", args.cli)
    seeds.build()
    print("seeds built in %.1f s; %d cases, %d at a time, work folder %s" % (
        time.monotonic() - t0, len(selected), args.jobs, work), flush=True)

    results, lock = [], threading.Lock()

    def one(numbered):
        r = run_case(numbered[1], numbered[0], args.cli, seeds, work / "cases", args.timeout)
        r.judge(known)
        with lock:
            results.append(r)
            print(r.line(), flush=True)

    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        list(pool.map(one, enumerate(selected)))

    counts = {}
    for r in results:
        counts[r.verdict] = counts.get(r.verdict, 0) + 1
    failed = [r for r in results if r.verdict not in ("pass", "known")]
    print("\n%d cases in %.1f s: %s" % (len(results), time.monotonic() - t0,
                                         ", ".join("%s %d" % (v, counts.get(v, 0))
                                                   for v in ("pass", "known") + FAILED + ("listed",))))
    if counts.get("setup"):
        print("setup errors (runner bugs): %d" % counts["setup"])
    if counts.get("listed"):
        print("listed in %s but passing or failing otherwise: %d" % (Path(args.known).name, counts["listed"]))
    listed = Path(args.known).name if args.known else "no list"
    if counts.get("known"):
        print("\nknown failures (%s; not counted as failed):" % listed)
        for r in sorted((r for r in results if r.verdict == "known"), key=lambda r: r.case.name):
            print("  " + r.line())
    else:
        print("known failures: none (%s lists %d cases)" % (listed, len(known)))
    if failed:
        print("\nfailures:")
        for r in sorted(failed, key=lambda r: (r.verdict, r.case.name)):
            print("  " + r.line())
    if args.keep:
        print("work folder kept: %s (cases/NNNN/case.txt names each case)" % work)
    else:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
