// Chunk residency in the page, the mapper's idea on the client: the chunks in view come first, then
// the nearest, as many as fit the splat budget; one SplatMesh per chunk, fetched a few at a time
// and disposed (GPU textures freed) as soon as it falls out of the chosen set.
import * as THREE from "three";
import { ExtSplats, SplatMesh } from "@sparkjsdev/spark";
import { ChunkInfo, MapInfo, PackedChunk, fetchChunk } from "./api";

// Spark keeps splats in textures 2048 wide and reads only whole rows of its arrays.
const ROW = 2048;

export interface StreamStats {
  loaded: number; // chunks with a mesh in the scene
  loading: number;
  splats: number; // Gaussians in loaded and loading chunks
  peakSplats: number; // the most `splats` has been since the page opened
  budget: number;
  fetches: number;
  disposed: number;
  failed: number;
  fetchMs: number[]; // per chunk: request to typed arrays in hand
  errors: string[];
}

interface Slot {
  info: ChunkInfo;
  mesh?: SplatMesh;
  abort?: AbortController;
}

function padded(a: Uint32Array, splats: number): Uint32Array {
  const out = new Uint32Array(splats * 4);
  out.set(a);
  return out;
}

function toExtSplats(p: PackedChunk): ExtSplats {
  const rows = Math.max(1, Math.ceil(p.count / ROW)) * ROW;
  const extra: Record<string, unknown> = {};
  if (p.sh1) extra.sh1 = p.sh1;
  if (p.sh2) extra.sh2 = p.sh2;
  if (p.sh3a && p.sh3b) {
    extra.sh3a = p.sh3a;
    extra.sh3b = p.sh3b;
  }
  return new ExtSplats({
    extArrays: [padded(p.extA, rows), padded(p.extB, rows)],
    numSplats: p.count,
    extra,
  });
}

// The map's chunks by cube: one entry, or two where the cube has both levels of detail.
function byCube(map: MapInfo): ChunkInfo[][] {
  const cubes = new Map<string, ChunkInfo[]>();
  for (const c of map.chunks) {
    const key = c.coord.join(",");
    const same = cubes.get(key);
    if (same) same.push(c);
    else cubes.set(key, [c]);
  }
  return [...cubes.values()];
}

export class ChunkStreamer {
  readonly stats: StreamStats;
  private slots = new Map<string, Slot>();
  private box = new THREE.Box3();
  private cubes: ChunkInfo[][]; // per map, not per frame: choose() runs at every camera move

  constructor(
    private scene: THREE.Scene,
    public map: MapInfo,
    budget: number,
    private sh: number,
    private concurrency = 4,
    private onShown?: (id: string) => void, // a chunk's mesh entered the scene
  ) {
    this.stats = { loaded: 0, loading: 0, splats: 0, peakSplats: 0, budget, fetches: 0, disposed: 0, failed: 0, fetchMs: [], errors: [] };
    this.cubes = byCube(map);
  }

  // A newer checkpoint of the map: chunks it changed or removed leave the page now (the changed
  // come back at their new content when chosen again). The origin stays the first map's.
  setMap(map: MapInfo, stale: Iterable<string>): void {
    map.origin = this.map.origin;
    this.map = map;
    this.cubes = byCube(map);
    for (const id of stale) {
      const slot = this.slots.get(id);
      if (slot) this.drop(id, slot);
    }
  }

  // Each cube at the level of detail a view from `eye` draws, as the mapper trained it (beyond
  // far_level_distance of its centre the far level), or at its other level where the map lacks that
  // one: a visitor may go where the car never was.
  private atLevels(eye: THREE.Vector3): ChunkInfo[] {
    const far = this.map.far_level_distance ?? 0;
    const o = this.map.origin;
    const out: ChunkInfo[] = [];
    for (const same of this.cubes) {
      const c = same[0];
      const d = Math.hypot(
        (c.min[0] + c.max[0]) / 2 - o[0] - eye.x,
        (c.min[1] + c.max[1]) / 2 - o[1] - eye.y,
        (c.min[2] + c.max[2]) / 2 - o[2] - eye.z,
      );
      const wantFar = far > 0 && d > far;
      out.push(same.find((s) => (s.level === "far") === wantFar) ?? c);
    }
    return out;
  }

  // Chunks chosen for a camera at `eye` (scene coordinates, i.e. world minus the map's origin).
  choose(eye: THREE.Vector3, frustum: THREE.Frustum): ChunkInfo[] {
    const o = this.map.origin;
    const ranked = this.atLevels(eye).map((c) => {
      this.box.min.set(c.min[0] - o[0], c.min[1] - o[1], c.min[2] - o[2]);
      this.box.max.set(c.max[0] - o[0], c.max[1] - o[1], c.max[2] - o[2]);
      return { c, seen: frustum.intersectsBox(this.box), d: this.box.distanceToPoint(eye) };
    });
    ranked.sort((a, b) => (a.seen === b.seen ? a.d - b.d : a.seen ? -1 : 1));
    const out: ChunkInfo[] = [];
    let total = 0;
    for (const r of ranked) {
      if (total + r.c.count > this.stats.budget) continue;
      total += r.c.count;
      out.push(r.c);
    }
    return out;
  }

  // True when every chosen chunk has its mesh (nothing left to fetch or drop).
  update(eye: THREE.Vector3, frustum: THREE.Frustum): boolean {
    const want = this.choose(eye, frustum);
    const wanted = new Set(want.map((c) => c.id));
    for (const [id, slot] of this.slots) if (!wanted.has(id)) this.drop(id, slot);
    let settled = true;
    for (const c of want) {
      const slot = this.slots.get(c.id);
      if (slot?.mesh) continue;
      settled = false;
      if (!slot && this.stats.loading < this.concurrency) this.load(c);
    }
    return settled && this.stats.loading === 0;
  }

  private load(c: ChunkInfo): void {
    const slot: Slot = { info: c, abort: new AbortController() };
    this.slots.set(c.id, slot);
    this.stats.loading++;
    this.stats.splats += c.count;
    this.stats.peakSplats = Math.max(this.stats.peakSplats, this.stats.splats);
    this.stats.fetches++;
    const t0 = performance.now();
    fetchChunk(c.id, this.sh, slot.abort!.signal)
      .then(async (p) => {
        this.stats.fetchMs.push(performance.now() - t0);
        if (this.slots.get(c.id) !== slot) return; // dropped while in flight
        const mesh = new SplatMesh({ extSplats: toExtSplats(p) });
        const o = this.map.origin;
        mesh.position.set(p.origin[0] - o[0], p.origin[1] - o[1], p.origin[2] - o[2]);
        await mesh.initialized;
        if (this.slots.get(c.id) !== slot) {
          mesh.dispose();
          return;
        }
        slot.mesh = mesh;
        this.scene.add(mesh);
        this.onShown?.(c.id);
        this.stats.loaded++;
      })
      .catch((e: unknown) => {
        if (slot.abort?.signal.aborted) return;
        this.stats.failed++;
        this.stats.errors.push(String(e));
        if (this.slots.get(c.id) === slot) {
          this.slots.delete(c.id);
          this.stats.splats -= c.count;
        }
      })
      .finally(() => {
        this.stats.loading--;
        slot.abort = undefined;
      });
  }

  private drop(id: string, slot: Slot): void {
    this.slots.delete(id);
    this.stats.splats -= slot.info.count;
    if (slot.abort) slot.abort.abort();
    if (slot.mesh) {
      this.scene.remove(slot.mesh);
      slot.mesh.dispose();
      this.stats.loaded--;
      this.stats.disposed++;
    }
  }
}
