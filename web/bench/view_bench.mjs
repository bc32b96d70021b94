// Figures for bench/README.md: a map served by `diskchungs view`, measured from two sides.
//  - the server alone: every chunk fetched once over HTTP, one at a time (latency p50/p99, MB/s);
//  - the page in headless Chromium (software WebGL): time to the first frame with a chunk in it,
//    then a fly-through keyframe by keyframe (every --stride-th) under a splat budget: chunk fetch
//    latency as the page sees it, peak splats against the budget, fetches, disposals, failures.
//   node view_bench.mjs --cli DISKCHUNGS --map MAP --modules NODE_MODULES [--budget N] [--stride K]
//        [--chromium PATH] [--size 640x360] [--screenshot FILE.png] [--shot-kf N]
// --screenshot: after the fly-through, the page at keyframe N (default the middle one) with its chunk
// grid shown, saved once every chosen chunk is in.
// Prints a table and one JSON line.
import { spawn } from "node:child_process";
import { createRequire } from "node:module";
import { join, resolve } from "node:path";

const argv = process.argv.slice(2);
const opt = (n, f) => (argv.indexOf(n) >= 0 ? argv[argv.indexOf(n) + 1] : f);
const cli = opt("--cli"), map = opt("--map"), modules = opt("--modules");
if (!cli || !map || !modules) {
  console.error("usage: view_bench.mjs --cli DISKCHUNGS --map MAP --modules NODE_MODULES [--budget N] [--stride K]");
  process.exit(2);
}
const budget = Number(opt("--budget", "0"));
const stride = Number(opt("--stride", "10"));
const [w, h] = opt("--size", "640x360").split("x").map(Number);
const { chromium } = createRequire(join(resolve(modules), "package.json"))("playwright-core");

const pct = (xs, q) => {
  const s = [...xs].sort((a, b) => a - b);
  return s.length ? s[Math.min(s.length - 1, Math.floor(q * s.length))] : NaN;
};

const proc = spawn(cli, ["view", map, "--port", "0"], { stdio: ["ignore", "pipe", "inherit"] });
const url = await new Promise((res, rej) => {
  let out = "";
  proc.stdout.on("data", (d) => {
    out += d;
    const m = out.match(/at (http:\/\/\S+\/)/);
    if (m) res(m[1]);
  });
  proc.on("exit", (c) => rej(new Error(`view exited ${c}: ${out}`)));
});
let browser;
try {
  const info = await (await fetch(`${url}api/map`)).json();
  const server = [];
  let bytes = 0;
  const t0 = performance.now();
  for (const c of info.chunks) {
    const t = performance.now();
    const r = await fetch(`${url}api/chunk/${c.id}`);
    bytes += (await r.arrayBuffer()).byteLength;
    if (!r.ok) throw new Error(`chunk ${c.id}: HTTP ${r.status}`);
    server.push(performance.now() - t);
  }
  const serverSeconds = (performance.now() - t0) / 1000;

  browser = await chromium.launch({
    executablePath: opt("--chromium", "/usr/bin/chromium"),
    args: ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist", "--no-sandbox",
      "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run"],
  });
  const page = await browser.newPage({ viewport: { width: w, height: h } });
  const b = budget > 0 ? budget : Math.max(1, Math.floor(info.total_gaussians / 4));
  const tOpen = Date.now();
  await page.goto(`${url}?kf=0&budget=${b}`);
  await page.waitForFunction(() => window.viewer?.firstFrameMs !== undefined || window.viewer?.error, null, { timeout: 120000 });
  const firstFrame = await page.evaluate(() => window.viewer.firstFrameMs);
  await page.waitForFunction(() => window.viewer.ready || window.viewer.error, null, { timeout: 120000 });
  const settled = Date.now() - tOpen;
  let peak = 0;
  const views = Math.floor((info.keyframes.length - 1) / stride);
  const tFly = Date.now();
  for (let v = 0; v < views; ++v) {
    for (let k = 0; k < stride; ++k) await page.keyboard.press("k");
    await page.waitForFunction(() => window.viewer.ready || window.viewer.error, null, { timeout: 120000, polling: 50 });
    peak = Math.max(peak, await page.evaluate(() => window.viewer.streamer.stats.splats));
  }
  const flySeconds = (Date.now() - tFly) / 1000;
  const shot = opt("--screenshot");
  if (shot) {
    const kf = Number(opt("--shot-kf", String(Math.floor(info.keyframes.length / 2))));
    const p = await browser.newPage({ viewport: { width: w, height: h } });
    await p.goto(`${url}?kf=${kf}&budget=${b}`);
    await p.waitForFunction(() => window.viewer?.ready || window.viewer?.error, null, { timeout: 120000 });
    await p.keyboard.press("g");
    await p.waitForTimeout(500);
    await p.screenshot({ path: shot });
    await p.close();
  }
  const s = await page.evaluate(() => window.viewer.streamer.stats);
  const fig = {
    chunks: info.chunks.length,
    gaussians: info.total_gaussians,
    keyframes: info.keyframes.length,
    server_chunk_ms_p50: pct(server, 0.5),
    server_chunk_ms_p99: pct(server, 0.99),
    server_mb_per_s: bytes / 1e6 / serverSeconds,
    mean_chunk_kb: bytes / 1e3 / info.chunks.length,
    page_first_frame_ms: firstFrame,
    page_settled_ms: settled,
    page_chunk_fetch_ms_p50: pct(s.fetchMs, 0.5),
    page_chunk_fetch_ms_p99: pct(s.fetchMs, 0.99),
    budget: b,
    peak_splats: peak,
    views,
    fly_seconds: flySeconds,
    fetches: s.fetches,
    disposed: s.disposed,
    failed: s.failed,
  };
  for (const [k, v] of Object.entries(fig)) console.log(`${k.padEnd(26)} ${typeof v === "number" && !Number.isInteger(v) ? v.toFixed(1) : v}`);
  console.log("json " + JSON.stringify(fig));
} finally {
  if (browser) await browser.close();
  proc.kill("SIGINT");
}
