// The browser build and the native build use the same shader sources: both read
// crates/isogrid-gpu/shaders/modules.txt (build.rs on the Rust side, build.mjs here), the native
// passes name only its consts (checked by the Rust test `shader_sources_come_only_from_the_manifest`),
// and here the bundle's modules must equal the manifest's concatenations while no web source
// reads a .wgsl file by itself.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync, readdirSync, mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';
import { build, shaderManifest, shaderSources, SHADER_DIR } from '../build.mjs';

const web = join(dirname(fileURLToPath(import.meta.url)), '..');

test('every module the native renderer composes is in the manifest, with files that exist', () => {
  const m = shaderManifest();
  for (const name of ['cells', 'probe', 'expand', 'ewa', 'visibility', 'shade']) assert.ok(m[name], name);
  const listed = new Set(Object.values(m).flat());
  for (const f of readdirSync(SHADER_DIR).filter((f) => f.endsWith('.wgsl'))) assert.ok(listed.has(f), `${f} in no module`);
  // The Rust side turns the same lines into consts: each pass file names a const per module.
  const passes = join(SHADER_DIR, '..', 'src', 'passes');
  const rust = readdirSync(passes).map((f) => readFileSync(join(passes, f), 'utf8')).join('\n');
  for (const name of ['cells', 'probe', 'expand', 'ewa', 'visibility', 'shade']) {
    assert.match(rust, new RegExp(`\\b${name.toUpperCase()}\\b`), `native passes use ${name.toUpperCase()}`);
  }
  assert.doesNotMatch(rust, /include_str!\([^)]*\.wgsl/, 'a native pass includes a shader file itself');
});

test('the bundle holds exactly the manifest compositions, and no web source reads .wgsl itself', async () => {
  const out = mkdtempSync(join(tmpdir(), 'isogrid-web-dist-'));
  await build(out);
  const bundle = readFileSync(join(out, 'viewer.js'), 'utf8');
  const sources = shaderSources();
  for (const [name, code] of Object.entries(sources)) {
    assert.ok(bundle.includes(JSON.stringify(code)), `dist/viewer.js lacks module ${name} as the manifest composes it`);
  }
  for (const f of readdirSync(join(web, 'src'))) {
    const text = readFileSync(join(web, 'src', f), 'utf8');
    assert.doesNotMatch(text, /\.wgsl['"]/, `web/src/${f} names a .wgsl file`);
    assert.doesNotMatch(text, /@(vertex|fragment|compute)\b/, `web/src/${f} holds WGSL of its own`);
  }
  // The browser never needs the wgpu-only `@early_depth_test` the native cell raster may add.
  assert.ok(!Object.values(sources).some((s) => s.includes('@early_depth_test')));
  rmSync(out, { recursive: true });
});

test('the committed bundle (web/dist, embedded by isogrid serve) is the build of the current sources', async () => {
  const fresh = mkdtempSync(join(tmpdir(), 'isogrid-web-dist-'));
  await build(fresh);
  for (const f of ['viewer.js']) {
    assert.ok(
      readFileSync(join(fresh, f)).equals(readFileSync(join(web, 'dist', f))),
      `web/dist/${f} is stale: run npm run build in web/ and commit it`,
    );
  }
  rmSync(fresh, { recursive: true });
});

test('the frame flags the viewer sets are those of common.wgsl and their Rust twins', async () => {
  const camera = await import('../build/node/camera.js');
  const wgsl = readFileSync(join(SHADER_DIR, 'common.wgsl'), 'utf8');
  const rust = readFileSync(join(SHADER_DIR, '..', 'src', 'gpu_types.rs'), 'utf8');
  const names = [...wgsl.matchAll(/^const (FLAG_\w+): u32/gm)].map((m) => m[1]);
  assert.deepEqual(names, ['FLAG_OCCLUSION', 'FLAG_BACKFACE', 'FLAG_EWA', 'FLAG_LABELS']);
  for (const name of names) {
    const w = Number(new RegExp(`const ${name}: u32 = (\\d+)u;`).exec(wgsl)[1]);
    const r = Number(new RegExp(`const ${name}: u32 = (\\d+);`).exec(rust)[1]);
    assert.deepEqual([camera[name], camera[name]], [w, r], name);
  }
});

test('the frame uniforms the viewer writes match the WGSL struct and its Rust twin (size, clip plane place)', async () => {
  const { frameUniforms, presetCamera, FRAME_UNIFORM_BYTES } = await import('../build/node/camera.js');
  const wgsl = readFileSync(join(SHADER_DIR, 'common.wgsl'), 'utf8');
  const body = /struct FrameUniforms \{([^}]*)\}/.exec(wgsl)[1];
  // Every field is a 16-byte vector (gpu_types.rs keeps the layout rule-free that way).
  const fields = [...body.matchAll(/^\s*(\w+): (vec4<(?:f32|u32)>),/gm)].map((m) => m[1]);
  assert.equal(body.split('\n').filter((l) => /^\s*\w+:/.test(l)).length, fields.length, 'a FrameUniforms field that is not a vec4');
  const rust = readFileSync(join(SHADER_DIR, '..', 'src', 'gpu_types.rs'), 'utf8');
  const rustBytes = Number(/size_of::<FrameUniforms>\(\) == (\d+)/.exec(rust)[1]);
  assert.equal(16 * fields.length, rustBytes);
  assert.equal(FRAME_UNIFORM_BYTES, rustBytes);
  const camera = presetCamera(2, [0, 0, 0], [9, 9, 9], 40, 30);
  const grid = { spacing: [1, 1, 1], isoCode: 127.5, precisionBits: 8, bounds: [[0, 0, 0], [9, 9, 9]] };
  const clipAt = 4 * fields.indexOf('clip');
  const none = new Float32Array(frameUniforms(camera, grid, 0, 0));
  assert.equal(none.byteLength, rustBytes);
  assert.deepEqual([...none.subarray(clipAt, clipAt + 4)], [0, 0, 0, 0]);
  const flipped = new Float32Array(frameUniforms(camera, grid, 0, 0, { axis: 1, at: 5, flip: true }));
  assert.deepEqual([...flipped.subarray(clipAt, clipAt + 4)], [0, -1, 0, -5]);
});

test('the colour uniforms and sources the viewer writes match color.wgsl and their Rust twin', async () => {
  const colors = await import('../build/node/colors.js');
  const wgsl = readFileSync(join(SHADER_DIR, 'color.wgsl'), 'utf8');
  const rust = readFileSync(join(SHADER_DIR, '..', 'src', 'gpu_types.rs'), 'utf8');
  for (const name of ['COLOR_NONE', 'COLOR_RECORDS', 'COLOR_LABELS']) {
    const w = Number(new RegExp(`const ${name}: u32 = (\\d+)u;`).exec(wgsl)[1]);
    const r = Number(new RegExp(`const ${name}: u32 = (\\d+);`).exec(rust)[1]);
    assert.deepEqual([colors[name], colors[name]], [w, r], name);
  }
  // struct ColorUniforms { mapping: vec4, params: vec4, nan_albedo: vec4, table: array<vec4, N> }.
  const body = /struct ColorUniforms \{([^}]*)\}/.exec(wgsl)[1];
  const fields = [...body.matchAll(/^\s*(\w+): ([^,]+),/gm)].map((m) => [m[1], m[2]]);
  assert.deepEqual(fields.map(([n]) => n), ['mapping', 'params', 'nan_albedo', 'table']);
  const entries = Number(/table: array<vec4<f32>, (\d+)>/.exec(body)[1]);
  const rustBytes = /size_of::<ColorUniforms>\(\) == 48 \+ 16 \* (\d+)/.exec(rust);
  assert.equal(colors.COLOR_UNIFORMS_BYTES, 48 + 16 * entries);
  assert.equal(Number(rustBytes[1]), entries);
  // The bytes: NaN bits in params.z, the source in params.x, the table's first entry at 48.
  const mapping = { zero: 1, step: 0.5, nanCode: 65535 };
  const u = colors.colorUniforms(colors.COLOR_RECORDS, { map: 'gray', clim: [0, 4] }, mapping);
  const f32 = new Float32Array(u);
  const u32 = new Uint32Array(u);
  assert.deepEqual([...f32.subarray(0, 4)], [1, 0.5, 0, 0.25]);
  assert.deepEqual([...u32.subarray(4, 7)], [colors.COLOR_RECORDS, 65535, 0x7fc00000]);
  assert.ok(f32[12] < 0.01 && f32[12 + 4 * 255] > 0.9, 'gray runs from black to white');
  assert.equal(new Uint32Array(colors.colorUniforms(colors.COLOR_LABELS))[4], colors.COLOR_LABELS);
});
