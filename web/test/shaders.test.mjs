// The browser build and the native build use the same shader sources: both read
// crates/isogrid-gpu/shaders/modules.txt (build.rs on the Rust side, build.mjs here), the native
// passes name only its consts (checked by the Rust test `shader_sources_come_only_from_the_manifest`),
// and here the bundle's modules must equal the manifest's concatenations while no web source
// reads a .wgsl file by itself.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync, readdirSync, mkdtempSync } from 'node:fs';
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
});
