// The server's API (src/chungs/serve/view_server.hpp) and the packed chunk layout
// (src/chungs/serve/splat_pack.hpp), read as typed-array views: no per-Gaussian work here.

export interface ChunkInfo {
  id: string; // decimal: 64-bit ids do not fit a JavaScript number
  coord: [number, number, number];
  min: [number, number, number];
  max: [number, number, number];
  count: number;
  generation: number;
  level?: "near" | "far"; // which of its cube's two levels of detail (absent: near)
}

export interface CameraInfo {
  width: number;
  height: number;
  fx: number;
  fy: number;
  cx: number;
  cy: number;
}

export interface KeyframeInfo {
  id: number;
  frame: number;
  stamp: number;
  pose: number[][]; // 4x4 camera-to-world (x right, y down, z forward), rows
}

export interface MapInfo {
  version: number; // the server's count of checkpoints taken since it started (/api/events ids)
  checkpoint: number;
  chunk_size: number;
  far_level_distance?: number; // beyond it (metres, to a cube's centre) a view draws the far level; 0: one level
  sh_degree: number;
  total_gaussians: number;
  origin: [number, number, number];
  chunks: ChunkInfo[];
  keyframes: KeyframeInfo[];
  trajectory: [number, number, number][];
  camera: CameraInfo | null;
  sky: { width: number; height: number } | null; // the learned sky's texture (GET /api/sky), if any
  report: Record<string, unknown> | null;
}

// One /api/events `checkpoint` event: what the newest checkpoint changed (or `reload`: too far behind).
export interface CheckpointEvent {
  version: number;
  reload?: boolean;
  checkpoint?: number;
  added?: string[];
  changed?: string[];
  removed?: string[];
  pose?: number[][] | null;
  keyframes?: number;
  total_gaussians?: number;
}

// Waits (calling `waiting` each second) while a run beside the server has no checkpoint yet (503).
export async function fetchMap(waiting?: () => void): Promise<MapInfo> {
  for (;;) {
    const r = await fetch("api/map");
    if (r.status === 503 && waiting) {
      waiting();
      await new Promise((res) => setTimeout(res, 1000));
      continue;
    }
    if (!r.ok) throw new Error(`api/map: HTTP ${r.status} ${await r.text()}`);
    return (await r.json()) as MapInfo;
  }
}

export interface PackedChunk {
  count: number;
  shDegree: number;
  origin: [number, number, number]; // world metres; centres are relative to it
  extA: Uint32Array;
  extB: Uint32Array;
  sh1?: Uint32Array;
  sh2?: Uint32Array;
  sh3a?: Uint32Array;
  sh3b?: Uint32Array;
}

const MAGIC = "DCSPLAT1";

export function parsePacked(buf: ArrayBuffer): PackedChunk {
  const head = new DataView(buf);
  const magic = new TextDecoder().decode(new Uint8Array(buf, 0, 8));
  if (magic !== MAGIC) throw new Error(`not a packed chunk (magic ${JSON.stringify(magic)})`);
  const version = head.getUint32(8, true);
  if (version !== 1) throw new Error(`packed chunk version ${version}, this page reads 1`);
  const count = head.getUint32(12, true);
  const shDegree = head.getUint32(16, true);
  const start = head.getUint32(20, true);
  const origin: [number, number, number] = [
    head.getFloat64(24, true),
    head.getFloat64(32, true),
    head.getFloat64(40, true),
  ];
  const arrays = 2 + (shDegree >= 1 ? 1 : 0) + (shDegree >= 2 ? 1 : 0) + (shDegree >= 3 ? 2 : 0);
  if (buf.byteLength !== start + arrays * 16 * count)
    throw new Error(`packed chunk of ${buf.byteLength} bytes, expected ${start + arrays * 16 * count}`);
  const view = (k: number) => new Uint32Array(buf, start + k * 16 * count, 4 * count);
  return {
    count,
    shDegree,
    origin,
    extA: view(0),
    extB: view(1),
    sh1: shDegree >= 1 ? view(2) : undefined,
    sh2: shDegree >= 2 ? view(3) : undefined,
    sh3a: shDegree >= 3 ? view(4) : undefined,
    sh3b: shDegree >= 3 ? view(5) : undefined,
  };
}

export async function fetchChunk(id: string, sh: number, signal?: AbortSignal): Promise<PackedChunk> {
  const r = await fetch(`api/chunk/${id}?sh=${sh}`, { signal });
  if (!r.ok) throw new Error(`api/chunk/${id}: HTTP ${r.status} ${await r.text()}`);
  return parsePacked(await r.arrayBuffer());
}
