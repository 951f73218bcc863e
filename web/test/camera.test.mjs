// The browser viewer's camera (src/camera.ts) against the native rules it twins: a mirrored
// camera's picture is the plain one's mirror image (crates/isogrid/src/camera.rs, `Camera::basis`),
// and drags move the picture alike whether or not it is mirrored (the native orbit's rule,
// crates/isogrid-viewer/src/orbit.rs).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { basis, orbit, pan, presetCamera } from '../build/node/camera.js';

/** Image x of world point `p` (right of centre positive), as camera `c` draws it. */
function imageX(c, p) {
  const [right, , forward] = basis(c);
  const d = p.map((v, a) => v - c.eye[a]);
  const dot = (u) => u.reduce((t, v, a) => t + v * d[a], 0);
  return dot(right) / dot(forward);
}

test('a mirrored camera draws the mirror image, with the same up and view direction', () => {
  for (const view of [1, 2]) {
    const plain = presetCamera(view, [0, 0, 0], [10, 8, 6], 64, 48);
    const mirrored = presetCamera(view, [0, 0, 0], [10, 8, 6], 64, 48, true);
    const [r0, u0, f0] = basis(plain);
    const [r1, u1, f1] = basis(mirrored);
    assert.deepEqual(r1, r0.map((v) => -v));
    assert.deepEqual([u1, f1], [u0, f0]);
    for (const p of [[1, 2, 3], [9, 1, 5]]) assert.ok(Math.abs(imageX(mirrored, p) + imageX(plain, p)) < 1e-12);
  }
});

test('drags move the picture alike whether or not it is mirrored', () => {
  for (const mirrored of [false, true]) {
    const c = presetCamera(1, [0, 0, 0], [10, 10, 10], 100, 100, mirrored);
    // A rightward drag (main.ts: orbit by -dx) turns the object right: its near side moves right.
    const near = [c.target[0], c.target[1], c.target[2] + 4];
    assert.ok(imageX(orbit(c, -0.2, 0), near) > imageX(c, near), `mirrored ${mirrored}: orbit`);
    // A rightward drag (pan by -dx) moves the picture right.
    assert.ok(imageX(pan(c, -1, 0), c.target) > imageX(c, c.target), `mirrored ${mirrored}: pan`);
  }
});
