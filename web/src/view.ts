// The map's camera conventions in THREE's: poses are camera-to-world with x right, y down, z
// forward (as the mapper writes them); THREE's camera looks down -z with y up. Scene coordinates
// are world minus the map's origin, so float32 keeps millimetres kilometres away.
import * as THREE from "three";
import { CameraInfo, MapInfo } from "./api";

export function applyPose(camera: THREE.Camera, pose: number[][], origin: [number, number, number]): void {
  const m = new THREE.Matrix4().set(
    pose[0][0], -pose[0][1], -pose[0][2], pose[0][3] - origin[0],
    pose[1][0], -pose[1][1], -pose[1][2], pose[1][3] - origin[1],
    pose[2][0], -pose[2][1], -pose[2][2], pose[2][3] - origin[2],
    0, 0, 0, 1,
  );
  m.decompose(camera.position, camera.quaternion, camera.scale);
  camera.updateMatrixWorld(true);
}

// A projection with the map camera's intrinsics (principal point off centre included), for views
// that must match `diskchungs render` pixel for pixel.
export function applyIntrinsics(camera: THREE.PerspectiveCamera, k: CameraInfo, near: number, far: number): void {
  const p = new THREE.Matrix4().set(
    (2 * k.fx) / k.width, 0, 1 - (2 * k.cx) / k.width, 0,
    0, (2 * k.fy) / k.height, (2 * k.cy) / k.height - 1, 0,
    0, 0, -(far + near) / (far - near), (-2 * far * near) / (far - near),
    0, 0, -1, 0,
  );
  camera.projectionMatrix.copy(p);
  camera.projectionMatrixInverse.copy(p).invert();
  camera.near = near;
  camera.far = far;
}

// The trajectory as a line, each keyframe as a frustum of wire (its camera's field of view).
export function trajectoryOverlay(map: MapInfo): THREE.Group {
  const g = new THREE.Group();
  const o = map.origin;
  if (map.trajectory.length > 1) {
    const pts = map.trajectory.map((p) => new THREE.Vector3(p[0] - o[0], p[1] - o[1], p[2] - o[2]));
    g.add(new THREE.Line(new THREE.BufferGeometry().setFromPoints(pts), new THREE.LineBasicMaterial({ color: 0xffcc33 })));
  }
  const k = map.camera;
  if (k && map.keyframes.length) {
    const depth = Math.min(1, map.chunk_size * 0.05);
    const corners = [
      [0, 0], [k.width, 0], [k.width, k.height], [0, k.height],
    ].map(([u, v]) => new THREE.Vector3(((u - k.cx) / k.fx) * depth, ((v - k.cy) / k.fy) * depth, depth));
    const seg: THREE.Vector3[] = [];
    const apex = new THREE.Vector3();
    for (let i = 0; i < 4; ++i) seg.push(apex, corners[i], corners[i], corners[(i + 1) % 4]);
    const local = new THREE.BufferGeometry().setFromPoints(seg);
    const mat = new THREE.LineBasicMaterial({ color: 0x33ccff });
    for (const kf of map.keyframes) {
      const f = new THREE.LineSegments(local, mat);
      const p = kf.pose;
      // The frustum's points are in the keyframe's own frame (y down, z forward): its pose as is.
      new THREE.Matrix4()
        .set(
          p[0][0], p[0][1], p[0][2], p[0][3] - o[0],
          p[1][0], p[1][1], p[1][2], p[1][3] - o[1],
          p[2][0], p[2][1], p[2][2], p[2][3] - o[2],
          0, 0, 0, 1,
        )
        .decompose(f.position, f.quaternion, f.scale);
      g.add(f);
    }
  }
  return g;
}

export function chunkGrid(map: MapInfo): THREE.Group {
  const g = new THREE.Group();
  const o = map.origin;
  for (const c of map.chunks) {
    const box = new THREE.Box3(
      new THREE.Vector3(c.min[0] - o[0], c.min[1] - o[1], c.min[2] - o[2]),
      new THREE.Vector3(c.max[0] - o[0], c.max[1] - o[1], c.max[2] - o[2]),
    );
    g.add(new THREE.Box3Helper(box, new THREE.Color(0x446644)));
  }
  return g;
}
