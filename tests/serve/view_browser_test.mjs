// The viewer in a real browser (issue 24): a tiny map made with the CLI, served by `diskchungs view`,
// opened in headless Chromium (software WebGL) through playwright-core; once the chunks in view are
// in the page, a screenshot from a keyframe's pose and camera is scored against `diskchungs render`
// of the same pose (`diskchungs eval images`): PSNR >= --min-psnr passes. A failure leaves both
// images side by side in the work folder. Then the same map under a budget of about half of it,
// flown keyframe by keyframe: the page stays within the budget, fetches and drops chunks, and no
// request fails. A short street with a learned sky is compared the same way, with and without the
// sky drawn. Prints one JSON line of figures (chunk fetch latency, time to first frame).
//   node view_browser_test.mjs --cli DISKCHUNGS --modules NODE_MODULES [--chromium PATH] [--work DIR]
//        [--min-psnr 25] [--keep]
// Exit 77 (ctest: skipped) when Chromium or playwright-core is missing.
import { spawn, spawnSync } from "node:child_process";
import { existsSync, mkdirSync, mkdtempSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { createRequire } from "node:module";
import { tmpdir } from "node:os";
import { join, resolve } from "node:path";

const argv = process.argv.slice(2);
const opt = (name, fallback) => {
  const i = argv.indexOf(name);
  return i >= 0 && argv[i + 1] !== undefined ? argv[i + 1] : fallback;
};
const cli = opt("--cli");
const modules = opt("--modules");
const chromiumPath = opt("--chromium", "/usr/bin/chromium");
const minPsnr = Number(opt("--min-psnr", "25"));
const keep = argv.includes("--keep");
if (!cli || !modules) {
  console.error("usage: view_browser_test.mjs --cli DISKCHUNGS --modules NODE_MODULES [--chromium PATH]");
  process.exit(2);
}
const skip = (why) => {
  console.log(`SKIP: ${why}`);
  process.exit(77);
};
if (!existsSync(chromiumPath)) skip(`no Chromium at ${chromiumPath} (apt-get install chromium)`);
let chromium;
try {
  ({ chromium } = createRequire(join(resolve(modules), "package.json"))("playwright-core"));
} catch (e) {
  skip(`playwright-core not found in ${modules} (build the target web): ${e.message}`);
}

const work = opt("--work") ?? mkdtempSync(join(tmpdir(), "chungs_view_"));
mkdirSync(work, { recursive: true });
const t0 = Date.now();
const say = (m) => console.log(`[${((Date.now() - t0) / 1000).toFixed(1)} s] ${m}`);
const failures = [];
const check = (ok, what) => {
  if (!ok) failures.push(what);
  say(`${ok ? "ok  " : "FAIL"} ${what}`);
};

function runCli(args) {
  const r = spawnSync(cli, args, { encoding: "utf8", env: { ...process.env, OMP_NUM_THREADS: "2" } });
  if (r.status !== 0) throw new Error(`diskchungs ${args.join(" ")}: exit ${r.status}\n${r.stdout}${r.stderr}`);
  return r.stdout;
}

// `diskchungs view` on a free port; resolves with the URL it prints.
function startViewer(map) {
  const p = spawn(cli, ["view", map, "--port", "0"], { stdio: ["ignore", "pipe", "pipe"] });
  let out = "";
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`view printed no URL in 20 s: ${out}`)), 20000);
    const take = (d) => {
      out += d;
      const m = out.match(/at (http:\/\/\S+\/)/);
      if (m) {
        clearTimeout(timer);
        resolve({ proc: p, url: m[1] });
      }
    };
    p.stdout.on("data", take);
    p.stderr.on("data", take);
    p.on("exit", (code) => reject(new Error(`view exited (${code}) before serving: ${out}`)));
  });
}

const percentile = (xs, q) => {
  const s = [...xs].sort((a, b) => a - b);
  return s.length ? s[Math.min(s.length - 1, Math.floor(q * s.length))] : NaN;
};

async function openViewer(browser, url, query, size) {
  const page = await browser.newPage({ viewport: size });
  const logs = [];
  page.on("console", (m) => logs.push(m.text()));
  page.on("pageerror", (e) => logs.push(String(e)));
  // A loaded machine (ctest -j2 beside a mapping run) can take well over the default 30 s.
  await page.goto(`${url}?${query}`, { timeout: 120000 });
  try {
    await page.waitForFunction(() => window.viewer && (window.viewer.ready || window.viewer.error), null, {
      timeout: 90000,
      polling: 100,
    });
  } catch (e) {
    throw new Error(`page never settled: ${e.message}\n${logs.join("\n")}`);
  }
  const err = await page.evaluate(() => window.viewer.error);
  if (err) throw new Error(`page error: ${err}\n${logs.join("\n")}`);
  return page;
}

// Both images in one PNG, viewer left, render right (drawn by the browser: no image package).
async function sideBySide(browser, a, b, out) {
  const page = await browser.newPage();
  const uri = (f) => `data:image/png;base64,${readFileSync(f).toString("base64")}`;
  const png = await page.evaluate(
    async ([x, y]) => {
      const load = (s) => new Promise((r) => { const i = new Image(); i.onload = () => r(i); i.src = s; });
      const [ia, ib] = await Promise.all([load(x), load(y)]);
      const c = document.createElement("canvas");
      c.width = ia.width + ib.width;
      c.height = Math.max(ia.height, ib.height);
      const g = c.getContext("2d");
      g.drawImage(ia, 0, 0);
      g.drawImage(ib, ia.width, 0);
      return c.toDataURL("image/png").split(",")[1];
    },
    [uri(a), uri(b)],
  );
  writeFileSync(out, Buffer.from(png, "base64"));
  await page.close();
}

async function liveRun(browser) {
  const room = join(work, "live-room");
  const map = join(work, "live-map");
  rmSync(room, { recursive: true, force: true });
  rmSync(map, { recursive: true, force: true });
  // Long enough to outlast the page's start on a loaded machine; stopped once enough is measured.
  runCli(["-q", "synth", "room", "--out", room, "--frames", "240", "--width", "96", "--height", "72"]);
  const cfg = join(work, "live.yaml");
  writeFileSync(cfg, "mapper:\n  checkpoint_every: 1\n  checkpoint_seconds: 0\n  checkpoint_max_share: 0\n");
  const run = spawn(cli, ["-q", "run", "--dataset", `tum:${room}`, "--device", "cpu", "--out", map, "--no-eval",
    "--pacing", "anytime", "--speed", "0.05", "--final-iterations", "0", "--chunk-size", "1", "--config", cfg],
    { stdio: ["ignore", "ignore", "pipe"], env: { ...process.env, OMP_NUM_THREADS: "1" } });
  let runErr = "";
  run.stderr.on("data", (d) => (runErr += d));
  // When each checkpoint was first seen on disk (a look every 20 ms).
  const committed = new Map();
  const watch = setInterval(() => {
    try {
      const m = readFileSync(join(map, "manifest.txt"), "utf8").match(/^config checkpoint (\d+)$/m);
      if (m && !committed.has(Number(m[1]))) committed.set(Number(m[1]), Date.now());
    } catch {}
  }, 20);
  const v = spawn(cli, ["view", map, "--port", "0", "--wait", "--follow", "0.1"], { stdio: ["ignore", "pipe", "pipe"] });
  try {
    const url = await new Promise((res, rej) => {
      let out = "";
      const t = setTimeout(() => rej(new Error(`live view printed no URL: ${out}`)), 60000);
      v.stdout.on("data", (d) => {
        out += d;
        const m = out.match(/at (http:\/\/\S+\/)/);
        if (m) {
          clearTimeout(t);
          res(m[1]);
        }
      });
    });
    const page = await openViewer(browser, url, "kf=0&budget=100000000&follow=1", { width: 320, height: 240 });
    const readyAt = Date.now();
    say(`live page ready; run still mapping: ${run.exitCode === null}`);
    // Chunk updates of checkpoints committed after the page was ready, timed from the commit; until
    // 8 are timed, the run ends, or 60 s pass (then the run is stopped: its folder is thrown away).
    const measure = async () => {
      const { eventLog, shown, events, chartSamples } = await page.evaluate(() => ({
        eventLog: window.viewer.eventLog,
        shown: window.viewer.shown,
        events: window.viewer.events,
        chartSamples: window.viewer.chartSamples,
      }));
      const latencies = [];
      for (const e of eventLog) {
        const commit = committed.get(e.checkpoint);
        if (commit === undefined || commit < readyAt) continue;
        for (const id of e.ids) {
          const s = shown.find(([sid, at]) => sid === id && at >= e.heard);
          if (s) latencies.push(s[1] - commit);
        }
      }
      return { events, latencies, chartSamples };
    };
    let m = await measure();
    while (m.latencies.length < 8 && run.exitCode === null && Date.now() - readyAt < 60000) {
      await new Promise((r) => setTimeout(r, 500));
      m = await measure();
    }
    if (run.exitCode === null) await new Promise((r) => setTimeout(r, 3000)); // updates in flight land
    m = await measure();
    await page.close();
    if (run.exitCode !== null && run.exitCode !== 0) throw new Error(`live run failed (${run.exitCode}): ${runErr}`);
    return m;
  } finally {
    clearInterval(watch);
    v.kill("SIGINT");
    if (run.exitCode === null) {
      run.kill("SIGKILL");
      await new Promise((r) => run.once("exit", r));
    }
  }
}


// A screenshot of the page from the map's middle keyframe with the map's camera, scored against
// `render` of the same pose (PSNR, `diskchungs eval images`); a failure below --min-psnr leaves both
// images side by side (not for sky=0, which is expected to fall short outdoors). `query` adds page
// parameters.
async function compareWithRender(browser, url, map, info, name, query = "") {
  // The keyframe's pose as a one-line trajectory (4x4 per line) for `render`, with the map's camera.
  const kf = Math.floor(info.keyframes.length / 2);
  const poseFile = join(work, `${name}-pose.txt`);
  writeFileSync(poseFile, info.keyframes[kf].pose.flat().join(" ") + "\n");
  const renders = join(work, `${name}-render`);
  if (!existsSync(join(renders, "render_000000.png"))) runCli(["-q", "render", "--map", map, "--poses", poseFile, "--out", renders]);
  const cam = info.camera;
  const page = await openViewer(browser, url, `kf=${kf}&size=camera&overlays=0&hud=0${query}`, {
    width: cam.width,
    height: cam.height,
  });
  const stats = await page.evaluate(() => ({ ...window.viewer.streamer.stats, firstFrameMs: window.viewer.firstFrameMs }));
  say(`page settled: ${stats.loaded} chunks, ${stats.splats} splats`);
  const tag = name + query.replace(/[^a-z0-9]/gi, "");
  const shots = join(work, `${tag}-viewer`);
  rmSync(shots, { recursive: true, force: true });
  mkdirSync(shots, { recursive: true });
  const shot = join(shots, "render_000000.png");
  await page.locator("canvas").screenshot({ path: shot });
  await page.close();
  const scored = JSON.parse(runCli(["eval", "images", "--ref", renders, "--test", shots, "--json"]));
  const psnr = scored.mean_psnr ?? scored.images?.[0]?.psnr;
  if (!(psnr >= minPsnr) && !query.includes("sky=0")) {
    const both = join(work, `${tag}_viewer_vs_render.png`);
    await sideBySide(browser, shot, join(renders, "render_000000.png"), both);
    say(`side by side (viewer left, render right): ${both}`);
  }
  return { psnr, stats };
}

// A short street mapped with the outdoor preset, which learns a sky (sky.bin): the page must draw it
// behind the splats as `render` composites it. Scored against `render` with the sky and without it
// (sky=0): the sky must bring the page at least 1 dB nearer, and with it the page passes the bar.
async function streetWithSky(browser) {
  const map = join(work, "street-map");
  rmSync(map, { recursive: true, force: true });
  rmSync(join(work, "street-render"), { recursive: true, force: true });
  runCli(["-q", "run", "--dataset", "synth-street:length=40,width=240,height=72,seed=15", "--device", "cpu", "--out", map,
    "--no-eval", "--iterations", "20", "--final-iterations", "60", "--chunk-size", "10"]);
  const v = await startViewer(map);
  try {
    const info = await (await fetch(`${v.url}api/map`)).json();
    check(info.sky !== null, `street map: ${info.chunks.length} chunks, sky ${info.sky ? `${info.sky.width}x${info.sky.height}` : "missing"}`);
    const withSky = await compareWithRender(browser, v.url, map, info, "street");
    const without = await compareWithRender(browser, v.url, map, info, "street", "&sky=0");
    return { withSky: withSky.psnr, without: without.psnr };
  } finally {
    v.proc.kill("SIGINT");
    await new Promise((r) => v.proc.once("exit", r));
  }
}

let viewer;
let browser;
let status = 1;
try {
  // A room of 1 m chunks, a few seconds of mapping on the CPU.
  const room = join(work, "room");
  const map = join(work, "map");
  rmSync(room, { recursive: true, force: true });
  rmSync(map, { recursive: true, force: true });
  rmSync(join(work, "room-render"), { recursive: true, force: true });
  runCli(["-q", "synth", "room", "--out", room, "--frames", "10", "--width", "128", "--height", "96"]);
  runCli(["-q", "run", "--dataset", `tum:${room}`, "--device", "cpu", "--out", map, "--no-eval", "--iterations", "10",
    "--final-iterations", "40", "--chunk-size", "1"]);
  say("map made");

  viewer = await startViewer(map);
  say(`viewer at ${viewer.url}`);
  const info = await (await fetch(`${viewer.url}api/map`)).json();
  check(info.chunks.length >= 2 && info.keyframes.length >= 2, `map of ${info.chunks.length} chunks, ${info.keyframes.length} keyframes`);

  browser = await chromium.launch({
    executablePath: chromiumPath,
    // Software WebGL; and nothing reaching out: this machine's network is closed.
    args: ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist", "--no-sandbox",
      "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run",
      "--disable-quic"],
  });
  const { psnr, stats: full } = await compareWithRender(browser, viewer.url, map, info, "room");
  check(psnr >= minPsnr, `viewer against render from keyframe ${Math.floor(info.keyframes.length / 2)}: PSNR ${psnr?.toFixed(2)} dB (>= ${minPsnr})`);
  check(full.failed === 0 && full.loaded === info.chunks.length, `every chunk fetched once, none failed (${full.fetches} fetches)`);

  // Streaming under a budget of about half the map, keyframe by keyframe.
  const budget = Math.max(1, Math.floor(info.total_gaussians / 2));
  const p2 = await openViewer(browser, viewer.url, `kf=0&budget=${budget}`, { width: 320, height: 240 });
  for (let i = 1; i < info.keyframes.length; ++i) {
    await p2.keyboard.press("k");
    await p2.waitForFunction(() => window.viewer.ready || window.viewer.error, null, { timeout: 60000, polling: 100 });
  }
  const s2 = await p2.evaluate(() => window.viewer.streamer.stats);
  const peak = s2.peakSplats; // the page's own high-water mark, kept as each chunk is requested
  check(peak <= budget, `splats in the page stayed within the budget: peak ${peak} of ${budget}`);
  check(s2.failed === 0, `no chunk request failed while flying (${s2.fetches} fetches, ${s2.disposed} disposed)`);
  check(s2.loaded < info.chunks.length, `the budget kept chunks out: ${s2.loaded} of ${info.chunks.length} in the page`);
  await p2.close();

  viewer.proc.kill("SIGINT");
  await new Promise((r) => viewer.proc.once("exit", r));
  viewer = undefined;

  // Live: a run checkpointing at every keyframe, paced slowly, `view --wait` beside it, the page open
  // while it maps. Each chunk a checkpoint adds or changes must be in the page within 2 s of the
  // commit (the median; the worst is printed). Commit times: when the manifest first names them.
  const live = await liveRun(browser);
  check(live.latencies.length > 0, `live: ${live.events} checkpoint events in the page, ${live.latencies.length} chunk updates timed`);
  check(live.chartSamples > 0, `live: the timeline charts hold ${live.chartSamples} samples of the run`);
  const liveMedian = percentile(live.latencies, 0.5);
  check(liveMedian <= 2000, `live: commit to chunk in the page, median ${liveMedian?.toFixed(0)} ms, worst ${Math.max(...live.latencies).toFixed(0)} ms (median <= 2000)`);

  const street = await streetWithSky(browser);
  check(street.withSky >= minPsnr, `street with its sky against render: PSNR ${street.withSky?.toFixed(2)} dB (>= ${minPsnr})`);
  check(street.withSky >= street.without + 1, `the sky drawn brings the page nearer render: ${street.withSky?.toFixed(2)} dB against ${street.without?.toFixed(2)} dB without (>= 1 dB)`);

  const fetchMs = [...full.fetchMs, ...s2.fetchMs];
  console.log(
    "figures " +
      JSON.stringify({
        psnr_db: psnr,
        street_psnr_db: { sky: street.withSky, no_sky: street.without },
        chunks: info.chunks.length,
        gaussians: info.total_gaussians,
        first_frame_ms: full.firstFrameMs,
        chunk_fetch_ms_p50: percentile(fetchMs, 0.5),
        chunk_fetch_ms_p99: percentile(fetchMs, 0.99),
        fetches: fetchMs.length,
        streaming: { budget, fetches: s2.fetches, disposed: s2.disposed, peak_splats: peak },
        live_commit_to_page_ms: { median: liveMedian, worst: Math.max(...live.latencies), n: live.latencies.length },
      }),
  );
  status = failures.length ? 1 : 0;
} catch (e) {
  console.error(`FAIL: ${e.stack ?? e}`);
  status = 1;
} finally {
  if (browser) await browser.close();
  if (viewer) {
    viewer.proc.kill("SIGINT");
    await new Promise((r) => viewer.proc.once("exit", r));
  }
  if (status === 0 && !keep && !opt("--work")) rmSync(work, { recursive: true, force: true });
  else say(`work folder kept: ${work}`);
}
console.log(status === 0 ? "view_browser_test: passed" : `view_browser_test: FAILED: ${failures.join("; ")}`);
process.exit(status);
