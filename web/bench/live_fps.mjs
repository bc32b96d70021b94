// The mapper's speed with the viewer beside it (issue 24: `run --view` with one page open may cost
// at most 5 % of its FPS). The same fixed-pacing run repeated in turns: alone, with `--view` and no
// page, with `--view` and a page following it in headless Chromium (software WebGL).
//   node live_fps.mjs --cli DISKCHUNGS --modules NODE_MODULES --dataset KIND:PATH [--rounds 3]
//        [--run-args "..."] [--checkpoint-seconds 2] [--mapper-cpu 0] [--page-cpu 1] [--mapper-nice N]
//        [--chromium PATH]
// --mapper-cpu / --page-cpu pin the run (all its threads, the viewer's server among them, with
// OMP_NUM_THREADS=1) and Chromium (every process of it) to separate cores with taskset, so what is
// measured is what the server costs the mapper on its own core, not SwiftShader's drawing taking
// the mapper's core (a machine with a GPU draws the page there). SwiftShader's worker threads
// (named Thread<NN>) set their own affinity when they start, to vCPU 0 here whatever Chromium was
// started on: they drew on the mapper's core and cost it a quarter of its FPS at 30 s checkpoints,
// with its CPU per frame unchanged. So every thread of Chromium is pinned again every 250 ms, and a
// page run that ends with one of them allowed on the mapper's core fails. Run this script itself on
// the page's core too (taskset -c 1 node ...). --mapper-nice N runs it at that niceness (e.g. -5, as
// root) in a session of its own whose autogroup gets the same niceness: with autogroups on (Linux's
// default on desktops and this VM) a niceness orders threads only within one session, so only the
// group's own puts the run ahead of other people's builds on a shared machine. Each run also prints
// the CPU seconds that anything else took on the mapper's core while it ran (/proc/stat). The order
// of the modes turns round each round, so a drift of the machine's load spreads over all of them.
// Checkpoints every --checkpoint-seconds (the page hears of each one and fetches what changed).
// Prints FPS per run, the median per mode and the ratios of the medians to running alone, the same
// for frames per CPU second of the run process (/usr/bin/time), and one JSON line.
import { spawn, spawnSync } from "node:child_process";
import { chmodSync, mkdtempSync, readFileSync, readdirSync, rmSync, writeFileSync } from "node:fs";
import { createRequire } from "node:module";
import { tmpdir } from "node:os";
import { join, resolve } from "node:path";

const argv = process.argv.slice(2);
const opt = (n, f) => (argv.indexOf(n) >= 0 ? argv[argv.indexOf(n) + 1] : f);
const cli = opt("--cli"), modules = opt("--modules"), dataset = opt("--dataset");
if (!cli || !modules || !dataset) {
  console.error("usage: live_fps.mjs --cli DISKCHUNGS --modules NODE_MODULES --dataset KIND:PATH [--rounds N]");
  process.exit(2);
}
const rounds = Number(opt("--rounds", "3"));
const runArgs = opt("--run-args", "--device cpu --no-eval --iterations 20 --final-iterations 0").split(/\s+/);
const seconds = Number(opt("--checkpoint-seconds", "2"));
const mapperCpu = opt("--mapper-cpu"), pageCpu = opt("--page-cpu"), mapperNice = opt("--mapper-nice");
const { chromium } = createRequire(join(resolve(modules), "package.json"))("playwright-core");
const work = mkdtempSync(join(tmpdir(), "chungs_live_fps_"));
const cfg = join(work, "checkpoints.yaml");
writeFileSync(cfg, `mapper:\n  checkpoint_seconds: ${seconds}\n  checkpoint_max_share: 1\n`);
let chromiumPath = opt("--chromium", "/usr/bin/chromium");
if (pageCpu !== undefined) {
  // Playwright starts the executable it is given: a wrapper that pins it (children inherit).
  const wrapper = join(work, "chromium-pinned.sh");
  writeFileSync(wrapper, `#!/bin/sh\nexec taskset -c ${pageCpu} ${chromiumPath} "$@"\n`);
  chmodSync(wrapper, 0o755);
  chromiumPath = wrapper;
}
const browser = await chromium.launch({
  executablePath: chromiumPath,
  args: ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist", "--no-sandbox",
    "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run"],
});

// Every process below this script's but the run's (whose pid is `skip`), i.e. Chromium's.
function chromiumPids(skip) {
  const parent = new Map();
  for (const d of readdirSync("/proc")) {
    if (!/^\d+$/.test(d)) continue;
    try {
      // The command name, in parentheses, may hold blanks: the fields after it are fixed.
      const stat = readFileSync(`/proc/${d}/stat`, "utf8");
      parent.set(Number(d), Number(stat.slice(stat.lastIndexOf(")") + 2).split(" ")[1]));
    } catch {} // gone meanwhile
  }
  const below = (pid) => {
    for (let p = pid; p > 1; p = parent.get(p) ?? 0) {
      if (p === skip) return false;
      if (p === process.pid) return p !== pid;
    }
    return false;
  };
  return [...parent.keys()].filter(below);
}

// Threads of Chromium allowed anywhere but the page's core are pinned to it; returns their names.
function pinChromium(skip) {
  const moved = [];
  for (const pid of chromiumPids(skip)) {
    let tasks = [];
    try {
      tasks = readdirSync(`/proc/${pid}/task`);
    } catch {
      continue;
    }
    for (const tid of tasks)
      try {
        const status = readFileSync(`/proc/${pid}/task/${tid}/status`, "utf8");
        if (status.match(/Cpus_allowed_list:\s*(\S+)/)[1] === String(pageCpu)) continue;
        if (spawnSync("taskset", ["-p", "-c", String(pageCpu), tid], { stdio: "ignore" }).status === 0)
          moved.push(status.match(/Name:\s*(.*)/)[1]);
      } catch {}
  }
  return moved;
}

// CPU seconds spent on one core so far (all but idle, iowait and steal), from /proc/stat.
function busySeconds(cpu) {
  const line = readFileSync("/proc/stat", "utf8").split("\n").find((l) => l.startsWith(`cpu${cpu} `));
  const [user, nice, system, , , irq, softirq] = line.trim().split(/\s+/).slice(1).map(Number);
  return (user + nice + system + irq + softirq) / 100; // USER_HZ, 100 on Linux
}

async function once(mode) {
  const out = join(work, "map");
  rmSync(out, { recursive: true, force: true });
  const extra = mode === "alone" ? [] : ["--view", "0"];
  const args = ["-q", "run", "--dataset", dataset, "--out", out, "--config", cfg, ...runArgs, ...extra];
  let [cmd, cmdArgs] = mapperCpu !== undefined ? ["taskset", ["-c", mapperCpu, cli, ...args]] : [cli, args];
  if (mapperNice !== undefined) [cmd, cmdArgs] = ["nice", ["-n", mapperNice, cmd, ...cmdArgs]];
  // The session's autogroup at the same niceness, set before anything of the run starts.
  if (mapperNice !== undefined)
    [cmd, cmdArgs] = ["setsid", ["sh", "-c", `echo ${Number(mapperNice)} > /proc/self/autogroup; exec "$@"`, "sh", cmd, ...cmdArgs]];
  // The run's CPU seconds, all its threads (the server's among them): frames per CPU second do not
  // move with what other people's jobs take of the core, only with what the process itself spends.
  const cpuFile = join(work, "cpu.txt");
  [cmd, cmdArgs] = ["/usr/bin/time", ["-f", "%U %S", "-o", cpuFile, cmd, ...cmdArgs]];
  const env = { ...process.env, ...(mapperCpu !== undefined ? { OMP_NUM_THREADS: "1" } : {}) };
  const busy0 = mapperCpu !== undefined ? busySeconds(mapperCpu) : 0;
  const p = spawn(cmd, cmdArgs, { stdio: ["ignore", "pipe", "inherit"], env });
  const moved = new Set();
  const pinner =
    pageCpu !== undefined ? setInterval(() => pinChromium(p.pid).forEach((n) => moved.add(n)), 250) : undefined;
  let page;
  let text = "";
  p.stdout.on("data", async (d) => {
    text += d;
    const m = text.match(/viewer at (http:\/\/\S+\/)/);
    if (m && mode === "page" && !page) {
      page = await browser.newPage({ viewport: { width: 640, height: 360 } });
      await page.goto(`${m[1]}?follow=1`, { timeout: 0 }).catch(() => {}); // a short run may end first
    }
  });
  const code = await new Promise((r) => p.once("exit", r));
  const busy = mapperCpu !== undefined ? busySeconds(mapperCpu) - busy0 : 0;
  clearInterval(pinner);
  if (code !== 0) throw new Error(`run (${mode}) exited ${code}`);
  if (pageCpu !== undefined) {
    // What Chromium started since the last look, or moved back, is caught here.
    pinChromium(p.pid).forEach((n) => moved.add(n));
    const astray = pinChromium(p.pid);
    if (astray.length) throw new Error(`Chromium's threads ${astray.join(", ")} keep leaving vCPU ${pageCpu}`);
  }
  let seen = { events: 0, fetches: 0 };
  if (page) {
    seen = await page
      .evaluate(() => ({ events: window.viewer?.events ?? 0, fetches: window.viewer?.streamer?.stats.fetches ?? 0 }))
      .catch(() => seen);
    await page.close();
  }
  const r = JSON.parse(readFileSync(join(out, "report.json"), "utf8"));
  const [user, sys] = readFileSync(cpuFile, "utf8").trim().split("\n").pop().split(" ").map(Number);
  const frames = r.time.processing_fps * r.time.mapping_s;
  // The run's threads are all on the mapper's core: the rest of that core's busy time is others'.
  const foreign = mapperCpu !== undefined ? Math.max(0, busy - user - sys) : undefined;
  return { fps: r.time.processing_fps, perCpu: frames / (user + sys), foreign, moved: [...moved], ...seen };
}

const modes = ["alone", "view", "page"];
const fps = { alone: [], view: [], page: [] };
const perCpu = { alone: [], view: [], page: [] }; // frames per CPU second of the run process
const pageWork = [];
const foreign = { alone: [], view: [], page: [] }; // CPU seconds others took of the mapper's core
for (let i = 0; i < rounds; ++i)
  for (let j = 0; j < modes.length; ++j) {
    const m = modes[(i + j) % modes.length];
    const r = await once(m);
    fps[m].push(r.fps);
    perCpu[m].push(r.perCpu);
    if (m === "page") pageWork.push({ events: r.events, fetches: r.fetches });
    foreign[m].push(r.foreign);
    console.log(`round ${i + 1} ${m.padEnd(5)} ${r.fps.toFixed(3)} FPS, ${r.perCpu.toFixed(3)} frames per CPU s` +
      (m === "page" ? `, the page heard ${r.events} checkpoints and fetched ${r.fetches} chunks` : "") +
      (r.foreign !== undefined ? `; others took ${r.foreign.toFixed(1)} CPU s of vCPU ${mapperCpu} meanwhile` : "") +
      (r.moved.length ? `; pinned Chromium's ${r.moved.join(", ")} back to vCPU ${pageCpu}` : ""));
  }
await browser.close();
rmSync(work, { recursive: true, force: true });
const median = (xs) => {
  const s = [...xs].sort((a, b) => a - b);
  return s.length % 2 ? s[(s.length - 1) / 2] : (s[s.length / 2 - 1] + s[s.length / 2]) / 2;
};
for (const m of modes)
  console.log(`${m.padEnd(5)} median ${median(fps[m]).toFixed(3)} FPS, ratio to alone ${(median(fps[m]) / median(fps.alone)).toFixed(3)}; ` +
    `${median(perCpu[m]).toFixed(3)} frames per CPU s, ratio ${(median(perCpu[m]) / median(perCpu.alone)).toFixed(3)}`);
console.log("json " + JSON.stringify({
  fps,
  frames_per_cpu_s: perCpu,
  page: pageWork,
  foreign_cpu_s: foreign,
  ratio_view: median(fps.view) / median(fps.alone),
  ratio_page: median(fps.page) / median(fps.alone),
  cpu_ratio_view: median(perCpu.view) / median(perCpu.alone),
  cpu_ratio_page: median(perCpu.page) / median(perCpu.alone),
}));
