// Figures for bench/README.md: a map served by `diskchungs view`, measured from two sides.
//  - the server alone: every chunk fetched once over HTTP, one at a time (latency p50/p99, MB/s);
//  - the page in headless Chromium (software WebGL): time to the first frame with a chunk in it,
//    then a fly-through keyframe by keyframe (every --stride-th) under a splat budget: chunk fetch
//    latency as the page sees it, peak splats against the budget, fetches, disposals, failures.
//   node view_bench.mjs --cli DISKCHUNGS --map MAP --modules NODE_MODULES [--budget N] [--stride K]
//        [--chromium PATH] [--size 640x360] [--screenshot FILE.png] [--shot-kf N] [--shot-query Q]
//        [--shot-keys KEYS]
// --screenshot: after the fly-through, the page at keyframe N (default the middle one), saved once
// every chosen chunk is in; --shot-query adds page parameters (e.g. "overlays=0"), --shot-keys presses
// keys before it is taken (default without a query: g, the chunk grid). --stride 0 skips the
// fly-through (screenshots only).
// Every request the page makes is watched: an HTTP error or a failed request counts as failed; one
// the page itself cancelled (a chunk that left the chosen set while in flight) is counted apart.
// The peak splat count is the page's own high-water mark, kept as chunks are requested, so a
// moment between two samples cannot hide an excess.
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
if (!(stride >= 0)) throw new Error(`--stride ${opt("--stride")}: expected a whole number >= 0`);
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
  const requests = { failed: [], cancelled: 0, http_errors: [] };
  page.on("requestfailed", (r) => {
    // Chromium names a request the page aborted (AbortController) net::ERR_ABORTED.
    if (r.failure()?.errorText === "net::ERR_ABORTED") requests.cancelled++;
    else requests.failed.push(`${r.url()}: ${r.failure()?.errorText}`);
  });
  page.on("response", (r) => {
    if (r.status() >= 400) requests.http_errors.push(`${r.url()}: HTTP ${r.status()}`);
  });
  const b = budget > 0 ? budget : Math.max(1, Math.floor(info.total_gaussians / 4));
  const tOpen = Date.now();
  await page.goto(`${url}?kf=0&budget=${b}`);
  await page.waitForFunction(() => window.viewer?.firstFrameMs !== undefined || window.viewer?.error, null, { timeout: 120000 });
  const firstFrame = await page.evaluate(() => window.viewer.firstFrameMs);
  await page.waitForFunction(() => window.viewer.ready || window.viewer.error, null, { timeout: 120000 });
  const settled = Date.now() - tOpen;
  const views = stride > 0 ? Math.floor((info.keyframes.length - 1) / stride) : 0;
  const tFly = Date.now();
  for (let v = 0; v < views; ++v) {
    for (let k = 0; k < stride; ++k) await page.keyboard.press("k");
    await page.waitForFunction(() => window.viewer.ready || window.viewer.error, null, { timeout: 120000, polling: 50 });
  }
  const pageError = await page.evaluate(() => window.viewer.error);
  if (pageError) throw new Error(`the page failed: ${pageError}`);
  const flySeconds = (Date.now() - tFly) / 1000;
  const s = await page.evaluate(() => window.viewer.streamer.stats);
  // The fly-through's page leaves the cores to the screenshot's (software WebGL on a loaded machine).
  await page.close();
  const shot = opt("--screenshot");
  if (shot) {
    const kf = Number(opt("--shot-kf", String(Math.floor(info.keyframes.length / 2))));
    const p = await browser.newPage({ viewport: { width: w, height: h } });
    const query = opt("--shot-query");
    await p.goto(`${url}?kf=${kf}&budget=${b}${query ? `&${query}` : ""}`);
    await p.waitForFunction(() => window.viewer?.ready || window.viewer?.error, null, { timeout: 300000 });
    for (const key of opt("--shot-keys", query ? "" : "g")) await p.keyboard.press(key);
    await p.waitForTimeout(500);
    await p.screenshot({ path: shot });
    await p.close();
  }
  const fig = {
    chunks: info.chunks.length,
    gaussians: info.total_gaussians,
    sky: info.sky ? `${info.sky.width}x${info.sky.height}` : "none",
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
    peak_splats: s.peakSplats,
    views,
    fly_seconds: flySeconds,
    fetches: s.fetches,
    disposed: s.disposed,
    failed: s.failed,
    requests_failed: requests.failed.length + requests.http_errors.length,
    requests_cancelled: requests.cancelled,
  };
  for (const [k, v] of Object.entries(fig)) console.log(`${k.padEnd(26)} ${typeof v === "number" && !Number.isInteger(v) ? v.toFixed(1) : v}`);
  console.log("json " + JSON.stringify(fig));
  for (const e of [...requests.failed, ...requests.http_errors].slice(0, 10)) console.log(`failed: ${e}`);
} finally {
  if (browser) await browser.close();
  proc.kill("SIGINT");
}
