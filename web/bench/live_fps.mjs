// The mapper's speed with the viewer beside it (issue 24: `run --view` with one page open may cost
// at most 5 % of its FPS). The same fixed-pacing run, checkpointing at every keyframe, repeated in
// turns: alone, with `--view` and no page, with `--view` and a page following it in headless
// Chromium (software WebGL, so on a machine without a GPU the page's drawing competes for the CPU).
//   node live_fps.mjs --cli DISKCHUNGS --modules NODE_MODULES --dataset tum:ROOM [--rounds 2]
//        [--run-args "..."] [--chromium PATH]
// Prints processing FPS per run, the mean per mode and the ratios to running alone.
import { spawn } from "node:child_process";
import { mkdtempSync, readFileSync, rmSync, writeFileSync } from "node:fs";
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
const rounds = Number(opt("--rounds", "2"));
const runArgs = opt("--run-args", "--device cpu --no-eval --iterations 30 --final-iterations 0 --chunk-size 1").split(/\s+/);
const { chromium } = createRequire(join(resolve(modules), "package.json"))("playwright-core");
const work = mkdtempSync(join(tmpdir(), "chungs_live_fps_"));
const cfg = join(work, "every.yaml");
writeFileSync(cfg, "mapper:\n  checkpoint_every: 1\n  checkpoint_seconds: 0\n  checkpoint_max_share: 0\n");
const browser = await chromium.launch({
  executablePath: opt("--chromium", "/usr/bin/chromium"),
  args: ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist", "--no-sandbox",
    "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run"],
});

async function once(mode) {
  const out = join(work, "map");
  rmSync(out, { recursive: true, force: true });
  const extra = mode === "alone" ? [] : ["--view", "0"];
  const p = spawn(cli, ["-q", "run", "--dataset", dataset, "--out", out, "--config", cfg, ...runArgs, ...extra],
    { stdio: ["ignore", "pipe", "inherit"] });
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
  await new Promise((r) => p.once("exit", r));
  let events = 0;
  if (page) {
    events = await page.evaluate(() => window.viewer?.events ?? 0).catch(() => 0);
    await page.close();
  }
  const r = JSON.parse(readFileSync(join(out, "report.json"), "utf8"));
  return { fps: r.time.processing_fps, events };
}

const modes = ["alone", "view", "page"];
const fps = { alone: [], view: [], page: [] };
for (let i = 0; i < rounds; ++i)
  for (const m of modes) {
    const r = await once(m);
    fps[m].push(r.fps);
    console.log(`round ${i + 1} ${m.padEnd(5)} ${r.fps.toFixed(3)} FPS${m === "page" ? `, ${r.events} checkpoint events in the page` : ""}`);
  }
await browser.close();
rmSync(work, { recursive: true, force: true });
const mean = (xs) => xs.reduce((a, b) => a + b, 0) / xs.length;
for (const m of modes) console.log(`${m.padEnd(5)} mean ${mean(fps[m]).toFixed(3)} FPS, ratio to alone ${(mean(fps[m]) / mean(fps.alone)).toFixed(3)}`);
console.log("json " + JSON.stringify({ fps, ratio_view: mean(fps.view) / mean(fps.alone), ratio_page: mean(fps.page) / mean(fps.alone) }));
