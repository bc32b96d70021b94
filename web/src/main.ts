// The viewer page: the map's description, then chunks streamed into Spark by view and distance
// under a splat budget, with the trajectory, keyframe frusta and chunk grid drawn over them.
// Query parameters: kf=N starts at keyframe N's pose; size=camera sizes the canvas to the map's
// camera and uses its intrinsics (for pixel comparisons); budget=N splats (default 3,000,000);
// sh=0..3; overlays=0 and hud=0 hide the drawn lines and the text; follow=1 moves the camera to each
// new checkpoint's newest keyframe while a run writes the map (key F toggles it); charts=0|1 hides or
// shows the timeline charts (shown by default when the run left a timeline; key C); sky=0 leaves
// the map's learned sky out (key B); fov=DEG the vertical field of view (default: the map camera's
// horizontal one across the window).
// Keys: W/A/S/D/Q/E fly, mouse orbits; G grid, T trajectory and frusta, K next keyframe, F follow,
// C charts, B sky.
import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { SparkRenderer } from "@sparkjsdev/spark";
import { CheckpointEvent, MapInfo, fetchMap } from "./api";
import { Charts, fetchTimeline } from "./charts";
import { SkyBackground, fetchSky } from "./sky";
import { ChunkStreamer } from "./streamer";
import { applyIntrinsics, applyPose, chunkGrid, trajectoryOverlay } from "./view";

interface ViewerState {
  map?: MapInfo;
  streamer?: ChunkStreamer;
  firstFrameMs?: number; // page start to the first frame drawn with a chunk in it
  settledFrames: number; // frames drawn since every chosen chunk was in the scene
  ready: boolean; // settled for a while: what a screenshot should wait for
  error?: string;
  events: number; // checkpoint events heard
  // For tests of live updates, in ms since the epoch: each event when heard with the chunks it named
  // (added or changed), and each chunk mesh when it entered the scene.
  eventLog: { checkpoint: number; ids: string[]; heard: number }[];
  shown: [string, number][];
  chartSamples: number; // timeline samples in the charts
}

declare global {
  interface Window {
    viewer: ViewerState;
  }
}

const state: ViewerState = { settledFrames: 0, ready: false, events: 0, eventLog: [], shown: [], chartSamples: 0 };
window.viewer = state;
const params = new URLSearchParams(location.search);
const hud = document.getElementById("hud")!;
if (params.get("hud") === "0") hud.classList.add("hidden");

function intParam(name: string, fallback: number, lo: number, hi: number): number {
  const v = params.get(name);
  if (v === null) return fallback;
  const n = Number(v);
  if (!Number.isInteger(n) || n < lo || n > hi) throw new Error(`${name}=${v}: expected a whole number in ${lo}..${hi}`);
  return n;
}

async function start(): Promise<void> {
  const map = await fetchMap(() => (hud.textContent = "waiting for the run's first checkpoint..."));
  state.map = map;
  const fixedCamera = params.get("size") === "camera" && map.camera !== null;
  const width = fixedCamera ? map.camera!.width : innerWidth;
  const height = fixedCamera ? map.camera!.height : innerHeight;

  const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
  renderer.setPixelRatio(fixedCamera ? 1 : devicePixelRatio);
  renderer.setSize(width, height);
  renderer.setClearColor(0x000000, 1);
  document.body.appendChild(renderer.domElement);

  const scene = new THREE.Scene();
  // Drawn as `diskchungs render` draws by default: a 0.3 px^2 low-pass with the opacity compensation of
  // `raster.antialias` (Spark's blurAmount; preBlurAmount is the plain one), 3 sigma, alpha below 1/255
  // skipped, depth-sorted, float32 centres through the accumulation.
  // Spark sorts on a worker and calls onDirty when the new order (or a level-of-detail update) is
  // ready: the page draws then, instead of drawing every frame in case it had finished.
  let sparkDirty = false;
  const spark = new SparkRenderer({
    renderer,
    onDirty: () => {
      sparkDirty = true;
    },
    preBlurAmount: 0,
    blurAmount: 0.3,
    maxStdDev: 3,
    minAlpha: 1 / 255,
    sortRadial: false,
    accumExtSplats: true,
  });
  scene.add(spark);

  // The map's sky behind everything, as `render` composites it; redrawn at each checkpoint of a run.
  const sky = new SkyBackground();
  scene.add(sky.mesh);
  let skyWanted = params.get("sky") !== "0";
  let skyVersion = 0;
  const refreshSky = async (m: MapInfo) => {
    sky.set(m.sky ? await fetchSky() : null);
    sky.mesh.visible &&= skyWanted;
    skyVersion++;
  };
  if (skyWanted) await refreshSky(map).catch((e: unknown) => console.warn(`sky: ${String(e)}`));

  const span = map.chunk_size * 50;
  // The map camera's horizontal field of view across the window (a street camera is wide and
  // short; 60 degrees tall would look far above what it saw); fov=DEG sets the vertical one.
  const k = map.camera;
  const sameWidth = k ? (2 * Math.atan(k.width / (2 * k.fx) / (width / height)) * 180) / Math.PI : 60;
  const fov = params.get("fov") !== null ? intParam("fov", 60, 10, 150) : Math.min(100, Math.max(20, sameWidth));
  const camera = new THREE.PerspectiveCamera(fov, width / height, 0.01, span);
  const kfIndex = intParam("kf", 0, 0, Math.max(0, map.keyframes.length - 1));
  if (map.keyframes.length) applyPose(camera, map.keyframes[kfIndex].pose, map.origin);
  else camera.position.set(0, -map.chunk_size, -map.chunk_size);
  if (fixedCamera) applyIntrinsics(camera, map.camera!, 0.01, span);

  const controls = new OrbitControls(camera, renderer.domElement);
  const ahead = new THREE.Vector3(0, 0, -1).applyQuaternion(camera.quaternion);
  controls.target.copy(camera.position).addScaledVector(ahead, map.chunk_size * 0.2);
  controls.update();
  if (map.keyframes.length) applyPose(camera, map.keyframes[kfIndex].pose, map.origin); // keep the exact pose

  const overlays = new THREE.Group();
  let traj = trajectoryOverlay(map);
  let grid = chunkGrid(map);
  grid.visible = false;
  overlays.add(traj, grid);
  overlays.visible = params.get("overlays") !== "0";
  scene.add(overlays);

  const budget = intParam("budget", 3_000_000, 1, 100_000_000);
  const sh = intParam("sh", map.sh_degree, 0, 3);
  const streamer = new ChunkStreamer(scene, map, budget, sh, 4, (id) =>
    state.shown.push([id, performance.timeOrigin + performance.now()]),
  );
  state.streamer = streamer;

  const charts = new Charts(document.body);
  const chartsWanted = params.get("charts") ?? (params.get("hud") === "0" ? "0" : "auto");
  charts.visible = false;
  const refreshCharts = async () => {
    const t = await fetchTimeline();
    if (!t.seconds.length) return;
    charts.show(t);
    state.chartSamples = charts.samples();
    if (!chartsDecided) charts.visible = true; // once: key C decides afterwards
    chartsDecided = true;
  };
  let chartsDecided = false;
  if (chartsWanted !== "0") refreshCharts().catch((e: unknown) => console.warn(`charts: ${String(e)}`));

  // A run writing the map: each checkpoint's event brings the new description; chunks it changed
  // are dropped and fetched again by the streamer, the overlays are drawn anew.
  let follow = params.get("follow") === "1";
  let busy = Promise.resolve();
  const events = new EventSource(`api/events?since=${map.version}`);
  events.addEventListener("checkpoint", (msg) => {
    const e = JSON.parse((msg as MessageEvent).data) as CheckpointEvent;
    state.events++;
    state.eventLog.push({
      checkpoint: e.checkpoint ?? -1,
      ids: [...(e.added ?? []), ...(e.changed ?? [])],
      heard: performance.timeOrigin + performance.now(),
    });
    busy = busy.then(async () => {
      const next = await fetchMap();
      const stale = new Set([...(e.changed ?? []), ...(e.removed ?? [])]);
      if (e.reload) for (const c of streamer.map.chunks) stale.add(c.id);
      streamer.setMap(next, stale);
      overlays.remove(traj, grid);
      const gridShown = grid.visible, trajShown = traj.visible;
      traj = trajectoryOverlay(next);
      grid = chunkGrid(next);
      traj.visible = trajShown;
      grid.visible = gridShown;
      overlays.add(traj, grid);
      if (chartsWanted !== "0") await refreshCharts();
      if (skyWanted) await refreshSky(next);
      if (follow && next.keyframes.length) {
        applyPose(camera, next.keyframes[next.keyframes.length - 1].pose, next.origin);
        const f = new THREE.Vector3(0, 0, -1).applyQuaternion(camera.quaternion);
        controls.target.copy(camera.position).addScaledVector(f, next.chunk_size * 0.2);
      }
    }).catch((err: unknown) => {
      state.error = `checkpoint event: ${String(err)}`;
    });
  });

  const keys = new Set<string>();
  let kfCursor = kfIndex;
  addEventListener("keydown", (e) => {
    keys.add(e.key.toLowerCase());
    if (e.key === "g") grid.visible = !grid.visible;
    if (e.key === "t") traj.visible = !traj.visible;
    if (e.key === "f") follow = !follow;
    if (e.key === "c") charts.visible = !charts.visible;
    if (e.key === "b") {
      skyWanted = !skyWanted;
      if (skyWanted) refreshSky(streamer.map).catch((err: unknown) => console.warn(`sky: ${String(err)}`));
      else sky.mesh.visible = false;
      skyVersion++;
    }
    const m = streamer.map;
    if (e.key === "k" && m.keyframes.length) {
      kfCursor = (kfCursor + 1) % m.keyframes.length;
      applyPose(camera, m.keyframes[kfCursor].pose, m.origin);
      const f = new THREE.Vector3(0, 0, -1).applyQuaternion(camera.quaternion);
      controls.target.copy(camera.position).addScaledVector(f, map.chunk_size * 0.2);
    }
  });
  addEventListener("keyup", (e) => keys.delete(e.key.toLowerCase()));
  if (!fixedCamera)
    addEventListener("resize", () => {
      renderer.setSize(innerWidth, innerHeight);
      camera.aspect = innerWidth / innerHeight;
      camera.updateProjectionMatrix();
    });

  const frustum = new THREE.Frustum();
  const projView = new THREE.Matrix4();
  let last = performance.now();
  let settledSince = 0;
  let lastLook = "";
  let quietFrames = 0;
  renderer.setAnimationLoop(() => {
    const now = performance.now();
    const dt = Math.min(0.1, (now - last) / 1000);
    last = now;
    const speed = map.chunk_size * 0.5 * dt * (keys.has("shift") ? 4 : 1);
    const move = new THREE.Vector3(
      (keys.has("d") ? 1 : 0) - (keys.has("a") ? 1 : 0),
      (keys.has("e") ? 1 : 0) - (keys.has("q") ? 1 : 0),
      (keys.has("s") ? 1 : 0) - (keys.has("w") ? 1 : 0),
    );
    if (move.lengthSq() > 0) {
      move.normalize().multiplyScalar(speed).applyQuaternion(camera.quaternion);
      camera.position.add(move);
      controls.target.add(move);
    }
    camera.updateMatrixWorld();
    projView.multiplyMatrices(camera.projectionMatrix, camera.matrixWorldInverse);
    frustum.setFromProjectionMatrix(projView);
    const settled = streamer.update(camera.position, frustum);
    // Drawn when something changes, a few frames after, and when Spark says its sort is done: an idle
    // page, or one following a run between checkpoints, leaves the CPU/GPU to the mapper beside it.
    // (It drew 30 frames after every change before: with chunks streaming in after each checkpoint of a
    // live run that was nearly every frame, and in software WebGL a sixth of the mapper's speed.)
    const look = `${camera.matrixWorld.elements.join()}|${streamer.stats.loaded}|${streamer.stats.disposed}|${overlays.visible}${traj.visible}${grid.visible}|${skyVersion}|${innerWidth}x${innerHeight}`;
    if (look !== lastLook) {
      lastLook = look;
      quietFrames = 0;
    }
    if (quietFrames++ < 3 || sparkDirty) {
      sparkDirty = false;
      renderer.render(scene, camera);
    }
    const s = streamer.stats;
    if (state.firstFrameMs === undefined && s.loaded > 0) state.firstFrameMs = now;
    if (settled) {
      if (state.settledFrames++ === 0) settledSince = now;
      state.ready = state.settledFrames >= 10 && now - settledSince >= 500;
    } else {
      state.settledFrames = 0;
      state.ready = false;
    }
    const m = streamer.map;
    hud.textContent =
      `checkpoint ${m.checkpoint}: ${m.chunks.length} chunks, ${m.total_gaussians.toLocaleString()} Gaussians` +
      (state.events ? ` (live: ${state.events} checkpoints seen${follow ? ", following" : ""})` : "") +
      "\n" +
      `in the page: ${s.loaded} chunks, ${s.splats.toLocaleString()} of ${s.budget.toLocaleString()} splats` +
      (s.loading ? `, ${s.loading} loading` : "") +
      (s.failed ? `\n${s.failed} chunk requests failed: ${s.errors[s.errors.length - 1]}` : "") +
      `\nmouse: orbit   W A S D Q E: fly   K: next keyframe   G: chunk grid   T: trajectory   F: follow   C: charts   B: sky`;
  });
}

start().catch((e: unknown) => {
  state.error = String(e);
  hud.textContent = `viewer: ${String(e)}`;
  hud.classList.remove("hidden");
});
