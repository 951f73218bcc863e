// The native camera conventions (crates/isogrid/src/camera.rs) and the frame uniforms
// (crates/isogrid-gpu/src/render/uniforms.rs), in f64 as there, so that `?view=N&size=WxH` gives
// the camera of `isogrid render --view N --size WxH`. World space: sample (i, j, k) at
// (i·sx, j·sy, k·sz); of the direction cosines only their handedness is taken, as natively: a
// grid whose axes mirror its world is drawn by mirrored cameras (`Camera::mirrored`).

export type Vec3 = [number, number, number];

export interface Camera {
  eye: Vec3;
  target: Vec3;
  up: Vec3;
  fovyDegrees: number;
  width: number;
  height: number;
  /** Image right is up × forward: the camera of a grid whose axes mirror its world (`directionsMirror`). */
  mirrored: boolean;
}

export const PRESET_FOVY = 35;
/** EWA Gaussian standard deviation in cells (`EWA_SIGMA_CELLS`). */
export const EWA_SIGMA_CELLS = 0.7;
export const FLAG_OCCLUSION = 1;
export const FLAG_BACKFACE = 2;
export const FLAG_EWA = 4;
/** A label grid: where two labels' surfaces coincide the front face wins (`label_back_face_depth`). */
export const FLAG_LABELS = 8;

const sub = (a: Vec3, b: Vec3): Vec3 => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const dot = (a: Vec3, b: Vec3) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a: Vec3, b: Vec3): Vec3 => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
function normalize(a: Vec3): Vec3 {
  const scale = Math.max(...a.map(Math.abs));
  const s = a.map((v) => v / scale) as Vec3;
  const n = Math.sqrt(dot(s, s));
  return s.map((v) => v / n) as Vec3;
}

/**
 * `Camera::preset`: view 1 from +z, view 2 oblique; both frame the box's bounding sphere. Mirrored
 * for a grid whose axes mirror its world, as the native front door's cameras are.
 */
export function presetCamera(view: number, lo: number[], hi: number[], width: number, height: number, mirrored = false): Camera {
  const center = [0, 1, 2].map((a) => 0.5 * (lo[a] + hi[a])) as Vec3;
  const d = sub(hi as Vec3, lo as Vec3);
  const radius = 0.5 * Math.max(Math.sqrt(dot(d, d)), 1e-9);
  const half = (PRESET_FOVY * Math.PI) / 180 * 0.5;
  const aspect = width / Math.max(height, 1);
  const halfH = Math.atan(Math.tan(half) * Math.min(aspect, 1));
  const distance = (1.05 * radius) / Math.sin(halfH);
  let dir: Vec3;
  if (view === 1) dir = [0, 0, 1];
  else if (view === 2) dir = normalize([0.62, 0.42, 0.66]);
  else throw new Error(`view ${view} is not 1 or 2`);
  return {
    eye: [0, 1, 2].map((a) => center[a] + distance * dir[a]) as Vec3,
    target: center,
    up: [0, 1, 0],
    fovyDegrees: PRESET_FOVY,
    width,
    height,
    mirrored,
  };
}

/** Widest a cell may project (pixels) for the compute raster (`MAX_COMPUTE_CELL_PIXELS`). */
export const MAX_COMPUTE_CELL_PIXELS = 32;

/**
 * `widest_cell_pixels` (isogrid-gpu options.rs): an upper estimate of a cell's projected width in
 * pixels, the cell diagonal seen at the grid box's nearest point (world bounds [lo, hi]) times 2 for
 * the perspective stretch towards the image corners; infinite with the eye inside the box.
 */
export function widestCellPixels(c: Camera, spacing: number[], [lo, hi]: [number[], number[]]): number {
  const distance = Math.sqrt([0, 1, 2].reduce((t, a) => t + Math.max(lo[a] - c.eye[a], c.eye[a] - hi[a], 0) ** 2, 0));
  const diagonal = Math.sqrt(spacing.reduce((t, s) => t + s * s, 0));
  const focalPixels = c.height / (2 * Math.tan((c.fovyDegrees * Math.PI) / 360));
  return distance <= 0 ? Infinity : (2 * diagonal * focalPixels) / distance;
}

/** Orthonormal (right, up, forward): image right, image up, view direction (`Camera::basis`). */
export function basis(c: Camera): [Vec3, Vec3, Vec3] {
  const forward = normalize(sub(c.target, c.eye));
  const right = normalize(cross(forward, c.up));
  const up = cross(right, forward);
  return [c.mirrored ? (right.map((v) => -v) as Vec3) : right, up, forward];
}

/**
 * Orbits the eye around the target by yaw/pitch radians (about world up and the unmirrored image
 * right); in a mirrored image the yaw turns the other way, so a drag turns the picture alike.
 */
export function orbit(c: Camera, yaw: number, pitch: number): Camera {
  const [right] = basis({ ...c, mirrored: false });
  if (c.mirrored) yaw = -yaw;
  const rot = (v: Vec3, axis: Vec3, ang: number): Vec3 => {
    const k = normalize(axis);
    const cs = Math.cos(ang), sn = Math.sin(ang);
    const kv = cross(k, v);
    const kd = dot(k, v) * (1 - cs);
    return [0, 1, 2].map((i) => v[i] * cs + kv[i] * sn + k[i] * kd) as Vec3;
  };
  let v = sub(c.eye, c.target);
  v = rot(v, c.up, yaw);
  const v2 = rot(v, right, pitch);
  // Keep away from the poles, where up and the view direction would be parallel.
  const cosUp = dot(normalize(v2), normalize(c.up));
  if (Math.abs(cosUp) < 0.995) v = v2;
  return { ...c, eye: [0, 1, 2].map((i) => c.target[i] + v[i]) as Vec3 };
}

/** Moves the eye towards (factor < 1) or away from the target. */
export function zoom(c: Camera, factor: number): Camera {
  const v = sub(c.eye, c.target);
  return { ...c, eye: [0, 1, 2].map((i) => c.target[i] + v[i] * factor) as Vec3 };
}

/** Moves eye and target along the image axes by (dx, dy) world units. */
export function pan(c: Camera, dx: number, dy: number): Camera {
  const [right, up] = basis(c);
  const m = [0, 1, 2].map((i) => right[i] * dx + up[i] * dy);
  return { ...c, eye: c.eye.map((v, i) => v + m[i]) as Vec3, target: c.target.map((v, i) => v + m[i]) as Vec3 };
}

export interface GridUniformInfo {
  spacing: number[];
  isoCode: number;
  precisionBits: number;
  bounds: [number[], number[]];
}

/**
 * A clip plane across world axis `axis` (0 x, 1 y, 2 z) at world coordinate `at`: the surface
 * beyond it (larger coordinates; smaller when `flip`) is cut away.
 */
export interface ClipPlane {
  axis: number;
  at: number;
  flip: boolean;
}

/** The clip plane as `FrameUniforms.clip`: (n, w) with dot(n, p) > w cut away; zeros for none. */
export function clipUniform(clip: ClipPlane | null): [number, number, number, number] {
  if (!clip) return [0, 0, 0, 0];
  const s = clip.flip ? -1 : 1;
  const n: [number, number, number, number] = [0, 0, 0, s * clip.at];
  n[clip.axis] = s;
  return n;
}

/** Bytes of `FrameUniforms` (the size assert in gpu_types.rs). */
export const FRAME_UNIFORM_BYTES = 128;

/**
 * `FrameUniforms` (common.wgsl): eye+near, right+tan·aspect, up+tan, forward+sigma, viewport,
 * spacing+iso code, params (precision, source, flags, frame), clip plane.
 */
export function frameUniforms(c: Camera, g: GridUniformInfo, flags: number, frame: number, clip: ClipPlane | null = null): ArrayBuffer {
  const [right, up, forward] = basis(c);
  const tan = Math.tan(((c.fovyDegrees * Math.PI) / 180) * 0.5);
  const aspect = c.width / c.height;
  const [lo, hi] = g.bounds;
  const center = [0, 1, 2].map((a) => 0.5 * (lo[a] + hi[a]));
  const radius = Math.sqrt([0, 1, 2].map((a) => (hi[a] - lo[a]) ** 2).reduce((x, y) => x + y)) * 0.5;
  const distance = Math.sqrt([0, 1, 2].map((a) => (c.eye[a] - center[a]) ** 2).reduce((x, y) => x + y));
  const near = 1e-5 * Math.max(distance + radius, 1e-6);
  const buf = new ArrayBuffer(FRAME_UNIFORM_BYTES);
  const f = new Float32Array(buf);
  const u = new Uint32Array(buf);
  f.set([...c.eye, near, ...right, tan * aspect, ...up, tan, ...forward, EWA_SIGMA_CELLS], 0);
  f.set([c.width, c.height, 1 / c.width, 1 / c.height], 16);
  f.set([g.spacing[0], g.spacing[1], g.spacing[2], g.isoCode], 20);
  u.set([g.precisionBits, 0, flags, frame], 24);
  f.set(clipUniform(clip), 28);
  return buf;
}

/** Whether the eye is outside the box (back-face culling is only safe then, as natively). */
export function eyeOutside(c: Camera, bounds: [number[], number[]]): boolean {
  return [0, 1, 2].some((a) => c.eye[a] < bounds[0][a] || c.eye[a] > bounds[1][a]);
}
