// The map's learned sky (GET /api/sky, src/chungs/serve/sky_pack.hpp) drawn behind the splats as
// `diskchungs render` composites it: rgb = splats + (1 - alpha) * sky(direction of the pixel). Spark
// blends its splats over what is already in the frame (premultiplied "over"), so the sky is a
// full-screen quad drawn first in the opaque pass: each fragment looks the texture up by its
// world direction with the renderer's mapping (render/sky.hpp: equirectangular about the sky frame's
// up, azimuth from east towards north, -pi at the left edge, row 0 at the zenith), and the GPU's
// bilinear filter between texel centres with azimuth repeating and elevation clamped does what the
// renderer's taps do.
import * as THREE from "three";

export interface SkyTexels {
  width: number;
  height: number;
  axes: number[]; // 9: rows east, north, up in world coordinates
  rgba: Uint8Array;
}

const MAGIC = "DCSKYTX1";
const HEADER = 64;

export function parseSky(buf: ArrayBuffer): SkyTexels {
  const magic = new TextDecoder().decode(new Uint8Array(buf, 0, 8));
  if (magic !== MAGIC) throw new Error(`not a packed sky (magic ${JSON.stringify(magic)})`);
  const head = new DataView(buf);
  const width = head.getUint32(8, true);
  const height = head.getUint32(12, true);
  const axes = Array.from({ length: 9 }, (_, i) => head.getFloat32(16 + 4 * i, true));
  if (buf.byteLength !== HEADER + 4 * width * height)
    throw new Error(`packed sky of ${buf.byteLength} bytes, expected ${HEADER + 4 * width * height}`);
  return { width, height, axes, rgba: new Uint8Array(buf, HEADER) };
}

// Texels no view trained (alpha 0: above and below the cameras' field of view, black in
// `render`) are filled for views wider than the cameras': in each column, from its trained texel
// nearest the gap, fading over a sixteenth of the height to the mean of those edge texels over all
// columns (the sky continued upwards and the ground downwards without streaks of one column's
// colour); columns nobody trained take the nearest column's. Trained texels stay as served.
export function fillUntrained(sky: SkyTexels): void {
  const { width: w, height: h, rgba } = sky;
  const trained = (x: number, y: number) => rgba[4 * (y * w + x) + 3] === 255;
  const first: number[] = [], last: number[] = [];
  const top = [0, 0, 0], bottom = [0, 0, 0];
  let columns = 0;
  for (let x = 0; x < w; ++x) {
    let a = -1, b = -1;
    for (let y = 0; y < h; ++y) if (trained(x, y)) (a = a < 0 ? y : a), (b = y);
    first.push(a);
    last.push(b);
    if (a < 0) continue;
    ++columns;
    for (let c = 0; c < 3; ++c) (top[c] += rgba[4 * (a * w + x) + c]), (bottom[c] += rgba[4 * (b * w + x) + c]);
  }
  if (!columns) return; // nothing trained: the black it is
  const fade = Math.max(1, h / 16);
  for (let x = 0; x < w; ++x) {
    if (first[x] < 0) continue;
    for (let y = 0; y < h; ++y) {
      if (trained(x, y)) continue;
      // Gaps inside the trained band (a texel between two trained ones) take the nearer edge's
      // colour unfaded; above the band fade to the top mean, below it to the bottom mean.
      const above = y < first[x], below = y > last[x];
      const edge = above ? first[x] : below ? last[x] : nearestTrained(x, y);
      const t = above || below ? Math.min(1, Math.abs(edge - y) / fade) : 0;
      const mean = above ? top : bottom;
      for (let c = 0; c < 3; ++c)
        rgba[4 * (y * w + x) + c] = Math.round((1 - t) * rgba[4 * (edge * w + x) + c] + (t * mean[c]) / columns);
    }
  }
  for (let x = 0; x < w; ++x) {
    if (first[x] >= 0) continue;
    let d = 1; // the nearest trained column, either way round (azimuth wraps)
    while (first[(x + d) % w] < 0 && first[(x - d + w) % w] < 0) ++d;
    const from = first[(x + d) % w] >= 0 ? (x + d) % w : (x - d + w) % w;
    for (let y = 0; y < h; ++y)
      for (let c = 0; c < 3; ++c) rgba[4 * (y * w + x) + c] = rgba[4 * (y * w + from) + c];
  }
  for (let i = 0; i < w * h; ++i) rgba[4 * i + 3] = 255;

  function nearestTrained(x: number, y: number): number {
    for (let d = 1; ; ++d) {
      if (y - d >= 0 && trained(x, y - d)) return y - d;
      if (y + d < h && trained(x, y + d)) return y + d;
    }
  }
}

// Null for a map without a sky (404).
export async function fetchSky(): Promise<SkyTexels | null> {
  const r = await fetch("api/sky");
  if (r.status === 404) return null;
  if (!r.ok) throw new Error(`api/sky: HTTP ${r.status} ${await r.text()}`);
  const sky = parseSky(await r.arrayBuffer());
  fillUntrained(sky);
  return sky;
}

const vertexShader = /* glsl */ `
out vec2 ndc;
void main() {
  ndc = position.xy;
  gl_Position = vec4(position.xy, 0.0, 1.0);
}`;

const fragmentShader = /* glsl */ `
uniform sampler2D sky;
uniform mat4 clipToWorldDir; // camera rotation times the inverse projection (no translation)
uniform mat3 axes;           // rows east, north, up
in vec2 ndc;
out vec4 colour;
const float PI = 3.14159265358979;
void main() {
  vec4 p = clipToWorldDir * vec4(ndc, 1.0, 1.0);
  vec3 d = p.xyz / p.w;
  vec3 enu = axes * d; // (east . d, north . d, up . d)
  float az = atan(enu.y, enu.x);
  float el = atan(enu.z, length(enu.xy));
  colour = vec4(texture(sky, vec2((az + PI) / (2.0 * PI), (0.5 * PI - el) / PI)).rgb, 1.0);
}`;

export class SkyBackground {
  readonly mesh: THREE.Mesh;
  private material: THREE.ShaderMaterial;
  private texture?: THREE.DataTexture;
  private inverseProjection = new THREE.Matrix4();

  constructor() {
    this.material = new THREE.ShaderMaterial({
      glslVersion: THREE.GLSL3,
      vertexShader,
      fragmentShader,
      uniforms: {
        sky: { value: null },
        clipToWorldDir: { value: new THREE.Matrix4() },
        axes: { value: new THREE.Matrix3() },
      },
      depthTest: false,
      depthWrite: false,
    });
    this.mesh = new THREE.Mesh(new THREE.PlaneGeometry(2, 2), this.material);
    this.mesh.frustumCulled = false;
    this.mesh.renderOrder = -1e9; // first of the opaque pass, so everything else lands on it
    this.mesh.visible = false;
    // The camera's matrices are those of this frame's render: set just before the quad is drawn.
    this.mesh.onBeforeRender = (_r, _s, camera) => this.follow(camera as THREE.PerspectiveCamera);
  }

  set(sky: SkyTexels | null): void {
    this.texture?.dispose();
    this.texture = undefined;
    this.mesh.visible = sky !== null;
    if (!sky) return;
    const t = new THREE.DataTexture(sky.rgba, sky.width, sky.height, THREE.RGBAFormat, THREE.UnsignedByteType);
    t.magFilter = THREE.LinearFilter;
    t.minFilter = THREE.LinearFilter; // no mipmaps: the renderer taps the full-size texture
    t.generateMipmaps = false;
    t.wrapS = THREE.RepeatWrapping; // azimuth wraps round
    t.wrapT = THREE.ClampToEdgeWrapping; // elevation stops at the poles' texel centres
    t.flipY = false; // row 0 (the zenith) at v = 0
    t.colorSpace = THREE.NoColorSpace; // the renderer's values, written to the canvas as they are
    t.needsUpdate = true;
    this.texture = t;
    this.material.uniforms.sky.value = t;
    const a = sky.axes;
    // Matrix3.set takes rows, so GLSL's axes * d dots d with each row.
    (this.material.uniforms.axes.value as THREE.Matrix3).set(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8]);
  }

  private follow(camera: THREE.PerspectiveCamera): void {
    const m = this.material.uniforms.clipToWorldDir.value as THREE.Matrix4;
    this.inverseProjection.copy(camera.projectionMatrix).invert();
    m.extractRotation(camera.matrixWorld).multiply(this.inverseProjection);
  }
}
