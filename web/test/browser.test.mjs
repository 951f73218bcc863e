// The viewer in real browsers (Debian's chromium and firefox-esr through puppeteer-core): its
// picture against the native renderer's (`isogrid render --backend gpu`, lavapipe) for the same
// file, camera and size, plain, coloured by an attribute (colours and the value under each pixel)
// and a label grid in its labels' colours, with labels hidden (only their pixels change, against
// the native cluster AOV), picked by a click, and cut open by clip planes (the label under each
// pixel against a march of the label volume); the messages of damaged, truncated and
// version-mismatch files; loading
// with Range requests (first frame before the last byte, each byte requested once) and from a
// server without Range support. Skips, saying why, where a browser, WebGPU or the isogrid binary
// is missing.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { existsSync, readFileSync, mkdtempSync, rmSync } from 'node:fs';
import { execFileSync, spawn } from 'node:child_process';
import { createInterface } from 'node:readline';
import { join, dirname } from 'node:path';
import { tmpdir } from 'node:os';
import { fileURLToPath } from 'node:url';
import puppeteer from 'puppeteer-core';
import { PNG } from 'pngjs';
import { build } from '../build.mjs';
import { startServer } from './server.mjs';
import { isogridBinary, sphereFile, resealHeader, resealSection, realFiles, coloredSphereFile, colouredLabelFile, labelFile, labelAt, packedFile, emptyFiles, placedSphereFile } from './fixtures.mjs';
import { basis, presetCamera } from '../build/node/camera.js';
import { parseCgc, labelText } from '../build/node/cgc.js';

const web = join(dirname(fileURLToPath(import.meta.url)), '..');
const BACKGROUND = [28, 30, 36];
const SIZE = [160, 120];

const BROWSERS = [
  {
    name: 'chromium',
    path: '/usr/bin/chromium',
    launch: { browser: 'chrome', args: ['--enable-unsafe-webgpu', '--no-sandbox', '--headless=new'] },
  },
  {
    name: 'firefox',
    path: '/usr/bin/firefox-esr',
    launch: {
      browser: 'firefox',
      extraPrefsFirefox: { 'dom.webgpu.enabled': true, 'gfx.webgpu.ignore-blocklist': true },
    },
  },
];

// A fresh build of the current sources (web/dist, the committed one, is checked in shaders.test.mjs).
const dist = join(web, 'build', 'dist');
await build(dist);
const bin = isogridBinary();
const sphere = sphereFile();
const sphereBytes = sphere ? new Uint8Array(readFileSync(sphere)) : null;
const sphereCells = sphereBytes ? parseCgc(sphereBytes).header.activeCells : 0;
const tiny = realFiles()[0][1];
const colored = bin && coloredSphereFile(48);
const coloredBytes = colored && new Uint8Array(readFileSync(colored));
const coloredF32 = bin && coloredSphereFile(48, 32);
const colouredLabels = bin && colouredLabelFile(48);
const labelled = bin && labelFile(48);
const labelBytes = labelled && new Uint8Array(readFileSync(labelled));
const spherePacked = sphere && new Uint8Array(readFileSync(packedFile(sphere)));
const coloredPacked = colored && new Uint8Array(readFileSync(packedFile(colored)));
const labelPacked = labelled && new Uint8Array(readFileSync(packedFile(labelled)));

/**
 * The native render of `file` with `view` at SIZE, RGBA8 rows; with `aov` (e.g. 'value' or
 * 'cluster') also that AOV's array ({ data, shape }). `extra`: more `isogrid render` flags.
 */
function nativeRender(file, view, extra = [], aov = null) {
  const dir = mkdtempSync(join(tmpdir(), 'isogrid-web-ref-'));
  const out = join(dir, `view${view}.png`);
  const aovArgs = aov ? ['--aov', `${aov}=${join(dir, 'aov.npy')}`] : [];
  execFileSync(bin, ['render', file, '--backend', 'gpu', '--view', String(view), '--size', SIZE.join('x'), ...extra, ...aovArgs, '-o', out], {
    stdio: 'ignore',
    env: { ...process.env, NODEVICE_SELECT: '1' },
  });
  const png = PNG.sync.read(readFileSync(out)).data;
  const result = aov ? { png, aov: readNpy(join(dir, 'aov.npy')) } : png;
  rmSync(dir, { recursive: true });
  return result;
}

/** A little-endian f4 or u4 .npy as a Float32Array or Uint32Array. */
function readNpy(path) {
  const b = readFileSync(path);
  const headerLength = b.readUInt16LE(8);
  const header = b.subarray(10, 10 + headerLength).toString('latin1');
  const data = b.subarray(10 + headerLength);
  const copy = new Uint8Array(data).buffer;
  if (/'descr': '<f4'/.test(header)) return new Float32Array(copy);
  if (/'descr': '<u4'/.test(header)) return new Uint32Array(copy);
  throw new Error(`${path}: unexpected .npy header ${header}`);
}

/** Mask agreement and colour agreement (within 8/255 on every channel) of two RGBA8 images. */
function compare(a, b) {
  let same = 0;
  let hits = 0;
  let close = 0;
  let worst = 0;
  const n = a.length / 4;
  for (let i = 0; i < n; i++) {
    const miss = (p) => BACKGROUND.every((c, k) => p[4 * i + k] === c);
    const [ma, mb] = [miss(a), miss(b)];
    if (ma === mb) same++;
    if (!ma && !mb) {
      hits++;
      const d = Math.max(...[0, 1, 2].map((k) => Math.abs(a[4 * i + k] - b[4 * i + k])));
      worst = Math.max(worst, d);
      if (d <= 8) close++;
    }
  }
  return { mask: same / n, colour: hits ? close / hits : 0, hits, worst };
}

/**
 * The camera of `isogrid render --view N` over the grid box [0, hi]³ at SIZE and the unit
 * direction of each pixel's centre ray, rows top to bottom, as the renderers cast them.
 */
function pixelRays(view, hi) {
  const [w, h] = SIZE;
  const cam = presetCamera(view, [0, 0, 0], [hi, hi, hi], w, h);
  const [right, up, forward] = basis(cam);
  const tan = Math.tan((cam.fovyDegrees * Math.PI) / 360);
  const dirs = [];
  for (let y = 0; y < h; y++) {
    for (let x = 0; x < w; x++) {
      const sx = (2 * (x + 0.5) / w - 1) * tan * (w / h);
      const sy = (1 - 2 * (y + 0.5) / h) * tan;
      const d = [0, 1, 2].map((a) => forward[a] + sx * right[a] + sy * up[a]);
      const m = Math.hypot(...d);
      dirs.push(d.map((v) => v / m));
    }
  }
  return { eye: cam.eye, dirs };
}

/**
 * The label each pixel of SIZE under `view` shows of `labelFile(n)` cut by a clip plane (axis
 * `axis` at `at`, cutting away the larger coordinates, or the smaller with `flip`), by marching
 * the label volume itself in steps of 1/20 voxel, each point taking its nearest sample's label
 * (binary surfaces cross every edge at its midpoint): from the first kept point inside the grid,
 * the label the ray enters at its first change of label, or the label it leaves where it enters
 * the background; -1 where it meets no label.
 */
function clippedLabels(n, view, axis, at, flip) {
  const { eye, dirs } = pixelRays(view, n - 1);
  const kept = (p) => (flip ? p[axis] >= at : p[axis] <= at);
  const inside = (p) => p.every((v) => v >= 0 && v <= n - 1);
  return dirs.map((d) => {
    let from = null;
    let shown = -1;
    for (let t = 0; t < 8 * n; t += 0.05) {
      const p = eye.map((v, a) => v + t * d[a]);
      if (!kept(p) || !inside(p)) {
        if (from !== null) break;
        continue;
      }
      const l = labelAt(...p.map(Math.round), n);
      if (from === null) {
        from = l;
        if (l !== 0) shown = l; // a label cut open shows itself only where nothing is entered
        continue;
      }
      if (l !== from) {
        shown = l !== 0 ? l : from;
        break;
      }
    }
    return shown;
  });
}

/**
 * The clipped sphere of `sphereFile()` (`generate sphere --size 48`: centre 23.5, radius 0.4·47,
 * index = world units) by ray casting the exact sphere, independently of the shaders: per pixel
 * of SIZE under `view`, 'near' where the first crossing is kept by the plane (axis `axis`, at
 * `at`, cutting away the larger coordinates, or the smaller with `flip`), 'far' where only the
 * second is, 'miss' otherwise; 'edge' within `margin` voxels of the plane or the silhouette,
 * where the sampled surface may fall either way.
 */
function clippedSphere(view, axis, at, flip, margin = 0.75) {
  const { eye, dirs } = pixelRays(view, 47);
  const centre = 23.5;
  const radius = 0.4 * 47;
  const kept = (p) => (flip ? p[axis] >= at : p[axis] <= at);
  const out = [];
  for (const d of dirs) {
    const o = eye.map((v) => v - centre);
    const b = o[0] * d[0] + o[1] * d[1] + o[2] * d[2];
    const disc = b * b - (o[0] ** 2 + o[1] ** 2 + o[2] ** 2 - radius * radius);
    // The ray's distance from the centre against the radius: near the silhouette either way.
    if (Math.abs(Math.sqrt(Math.max(0, o[0] ** 2 + o[1] ** 2 + o[2] ** 2 - b * b)) - radius) < margin) {
      out.push('edge');
      continue;
    }
    if (disc <= 0) {
      out.push('miss');
      continue;
    }
    const ts = [-b - Math.sqrt(disc), -b + Math.sqrt(disc)];
    const pts = ts.map((t) => eye.map((v, a) => v + t * d[a]));
    if (pts.some((p) => Math.abs(p[axis] - at) < margin)) {
      out.push('edge');
      continue;
    }
    out.push(kept(pts[0]) ? 'near' : kept(pts[1]) ? 'far' : 'miss');
  }
  return out;
}

for (const B of BROWSERS) {
  test(`viewer in ${B.name}`, { timeout: 240_000 }, async (t) => {
    if (!existsSync(B.path)) {
      t.skip(`no ${B.path}: install the Debian package to run this browser's tests`);
      return;
    }
    const files = { 'tiny.cgc': tiny };
    if (sphereBytes) {
      files['colored.cgc'] = coloredBytes;
      files['colored-f32.cgc'] = new Uint8Array(readFileSync(coloredF32));
      files['colored-labels.cgc'] = new Uint8Array(readFileSync(colouredLabels));
      files['colored-labels.cgcz'] = new Uint8Array(readFileSync(packedFile(colouredLabels)));
      files['labels.cgc'] = labelBytes;
      // Optional sections damaged past their checksums: the page names the structural problem.
      const edited = (bytes, kind, at, value) => {
        const b = bytes.slice();
        const sections = parseCgc(bytes).header.sections;
        const entry = sections.findIndex((x) => x.kind === kind);
        new DataView(b.buffer).setUint32(sections[entry].offset + at, value, true);
        return resealSection(b, entry);
      };
      files['badlabels.cgc'] = edited(labelBytes, 5, 0, 4);
      files['badattribute.cgc'] = edited(coloredBytes, 4, 4, 12);
      files['sphere48.cgc'] = sphereBytes;
      const damaged = sphereBytes.slice();
      damaged[sphereBytes.length - 100] ^= 0x10;
      files['damaged.cgc'] = damaged;
      files['truncated.cgc'] = sphereBytes.slice(0, sphereBytes.length - 1000);
      const future = sphereBytes.slice();
      future[8] = 9;
      files['future.cgc'] = resealHeader(future);
      files['sphere48.cgcz'] = spherePacked;
      files['colored.cgcz'] = coloredPacked;
      files['labels.cgcz'] = labelPacked;
      const damagedPacked = spherePacked.slice();
      damagedPacked[spherePacked.length >> 1] ^= 0x10;
      files['damaged.cgcz'] = damagedPacked;
      files['truncated.cgcz'] = spherePacked.slice(0, spherePacked.length - 1000);
      for (const [name, path] of emptyFiles()) files[name] = new Uint8Array(readFileSync(path));
      files['placed24.cgc'] = new Uint8Array(readFileSync(placedSphereFile()));
      files['placed24.cgcz'] = new Uint8Array(readFileSync(packedFile(placedSphereFile())));
    }
    const server = await startServer({ dist, files });
    const plain = await startServer({ dist, files, ranges: false });
    const slow = await startServer({ dist, files, delayMs: 300 });
    // A page that may start no worker: the packed rebuild falls back to the page's thread.
    const noWorkers = await startServer({ dist, files, pageHeaders: { 'Content-Security-Policy': "worker-src 'none'" } });
    const browser = await puppeteer.launch({ executablePath: B.path, headless: true, ...B.launch });
    const errors = [];
    const open = async (base, query) => {
      const page = await browser.newPage();
      page.on('console', (m) => m.type() === 'error' && errors.push(m.text()));
      await page.goto(`${base}/index.html?${query}`);
      const outcome = await page.evaluate(() => window.isogrid.ready.then(() => 'ready', (e) => `error: ${e.message}`));
      const stats = await page.evaluate(() => ({ ...window.isogrid.stats, message: document.getElementById('message').textContent }));
      return { page, outcome, stats };
    };
    try {
      const probe = await open(server.url, 'src=/tiny.cgc');
      if (/no WebGPU/.test(probe.stats.message)) {
        t.skip(`${B.name} offers no WebGPU adapter here: ${probe.stats.message}`);
        return;
      }
      assert.equal(probe.outcome, 'ready', probe.stats.message);
      if (!sphereBytes) {
        t.skip('no isogrid binary built (cargo build -p isogrid-cli): no file to compare with the native renderer');
        return;
      }
      await t.test('picture agrees with isogrid render on lavapipe, views 1 and 2, both cell rasters', async () => {
        for (const view of [1, 2]) {
          const { page, outcome, stats } = await open(server.url, `src=/sphere48.cgc&view=${view}&size=${SIZE.join('x')}`);
          assert.equal(outcome, 'ready', stats.message);
          assert.equal(stats.raster, 'compute', 'cells of a few pixels: the compute raster, as natively');
          const px = Buffer.from(await page.evaluate(() => window.isogrid.pixels()), 'base64');
          const c = compare(px, nativeRender(sphere, view));
          t.diagnostic(`${B.name} (${stats.presentation}) view ${view}: mask ${(100 * c.mask).toFixed(2)} %, colour within 8/255 on ${(100 * c.colour).toFixed(2)} % of ${c.hits} hits (worst ${c.worst})`);
          assert.ok(c.hits > 500, `only ${c.hits} common hits`);
          assert.ok(c.mask >= 0.995, `mask agreement ${c.mask}`);
          assert.ok(c.colour >= 0.99, `colour agreement ${c.colour}`);
          // Redraws of the view go through the visibility buffer, the probes and the newly
          // visible clusters (compiled after the first picture): the picture stays.
          await page.waitForFunction(() => window.isogrid.stats.restCompiled, { polling: 100 });
          const f = await page.evaluate(() => window.isogrid.frames(3));
          assert.ok(f.cells.full < sphereCells && f.cells.probe > 0, `culling in redraws: ${JSON.stringify(f.cells)}`);
          const again = compare(Buffer.from(await page.evaluate(() => window.isogrid.pixels()), 'base64'), nativeRender(sphere, view));
          t.diagnostic(`${B.name} view ${view}, redrawn: mask ${(100 * again.mask).toFixed(2)} %, colour within 8/255 on ${(100 * again.colour).toFixed(2)} %; cells ${JSON.stringify(f.cells)}`);
          assert.ok(again.mask >= 0.995 && again.colour >= 0.99, JSON.stringify(again));
        }
        // The other cell raster (auto takes the compute one at these views), as natively.
        const { page, outcome, stats } = await open(server.url, `src=/sphere48.cgc&view=2&size=${SIZE.join('x')}&raster=hardware`);
        assert.equal(outcome, 'ready', stats.message);
        assert.equal(stats.raster, 'hardware');
        const px = Buffer.from(await page.evaluate(() => window.isogrid.pixels()), 'base64');
        const c = compare(px, nativeRender(sphere, 2, ['--cell-raster', 'hardware']));
        t.diagnostic(`${B.name} view 2, hardware raster: mask ${(100 * c.mask).toFixed(2)} %, colour within 8/255 on ${(100 * c.colour).toFixed(2)} % of ${c.hits} hits (worst ${c.worst})`);
        assert.ok(c.hits > 500 && c.mask >= 0.995 && c.colour >= 0.99, JSON.stringify(c));
      });
      await t.test('clip plane: the cut-away side shows the far surface or the background', async () => {
        const size = SIZE.join('x');
        const shown = async (query) => {
          const { page, outcome, stats } = await open(server.url, `src=/sphere48.cgc&size=${size}&${query}`);
          assert.equal(outcome, 'ready', stats.message);
          const px = Buffer.from(await page.evaluate(() => window.isogrid.pixels()), 'base64');
          await page.close();
          return px;
        };
        // The kept side away from the eye shows the far surface; towards it (the flipped plane seen
        // from +z), the near surface or nothing.
        const cases = [[2, 'x:0.6', 0, 0.6, false, ['near', 'far', 'miss']], [1, '-x:0.4', 0, 0.4, true, ['near', 'miss']]];
        for (const [view, clip, axis, fraction, flip, kinds] of cases) {
          const whole = await shown(`view=${view}`);
          const cut = await shown(`view=${view}&clip=${clip}`);
          const ref = clippedSphere(view, axis, 47 * fraction, flip);
          const count = { near: 0, far: 0, miss: 0 };
          const agree = { near: 0, far: 0, miss: 0 };
          let nearSame = 0;
          for (let i = 0; i < ref.length; i++) {
            if (ref[i] === 'edge') continue;
            const hit = !BACKGROUND.every((c, k) => cut[4 * i + k] === c);
            count[ref[i]]++;
            if (hit === (ref[i] !== 'miss')) agree[ref[i]]++;
            const d = Math.max(...[0, 1, 2].map((k) => Math.abs(cut[4 * i + k] - whole[4 * i + k])));
            if (ref[i] === 'near' && d <= 8) nearSame++;
          }
          t.diagnostic(`${B.name} view ${view} clip ${clip}: ${JSON.stringify(agree)} of ${JSON.stringify(count)} pixels agree with the ray-cast sphere; ${nearSame} of ${count.near} kept pixels as unclipped`);
          // Each kind of pixel is present, so the test tells a plane from no plane and from a discard.
          for (const k of ['near', 'far', 'miss']) {
            if (kinds.includes(k)) assert.ok(count[k] > 200, `only ${count[k]} ${k} pixels`);
            assert.ok(agree[k] >= 0.99 * count[k], `${k}: ${agree[k]} of ${count[k]} agree`);
          }
          assert.ok(nearSame >= 0.99 * count.near, `kept surface changed: ${nearSame} of ${count.near}`);
        }
      });
      await t.test('coloured by an attribute: colours and values agree with isogrid render (map, range)', async () => {
        // (view, browser query, native flags): the default map over the stored range, another map
        // over another range.
        const range = parseCgc(coloredBytes).attribute.info.range;
        const clim = [range[0] + 0.25 * (range[1] - range[0]), range[0] + 0.6 * (range[1] - range[0])];
        // And f32 values, which the viewer codes at 16 bits itself (codesOf), as the native upload does.
        const cases = [
          ['colored.cgc', colored, 1, '', []],
          ['colored.cgc', colored, 2, `&cmap=turbo&clim=${clim.join(',')}`, ['--cmap', 'turbo', '--clim', clim.join(',')]],
          ['colored-f32.cgc', coloredF32, 2, '&cmap=rdbu', ['--cmap', 'rdbu']],
          // A label grid with an attribute is drawn by the attribute, as natively, labels hidden too.
          ['colored-labels.cgc', colouredLabels, 2, '&hide=2', ['--hide', '2']],
          // Packed, the label sections arrive after the attribute's head.
          ['colored-labels.cgcz', colouredLabels, 2, '&hide=2', ['--hide', '2']],
        ];
        for (const [file, path, view, query, flags] of cases) {
          const { page, outcome, stats } = await open(server.url, `src=/${file}&view=${view}&size=${SIZE.join('x')}${query}`);
          assert.equal(outcome, 'ready', stats.message);
          const px = Buffer.from(await page.evaluate(() => window.isogrid.pixels()), 'base64');
          const values = new Float32Array(new Uint8Array(Buffer.from(await page.evaluate(() => window.isogrid.values()), 'base64')).buffer);
          await page.close();
          const native = nativeRender(path, view, flags, 'value');
          const c = compare(px, native.png);
          // The value each pixel shows, against the native value AOV: the same code decoded.
          let both = 0;
          let same = 0;
          for (let i = 0; i < values.length; i++) {
            if (Number.isNaN(values[i]) || Number.isNaN(native.aov[i])) continue;
            both++;
            if (Math.abs(values[i] - native.aov[i]) <= 1e-5 * (range[1] - range[0])) same++;
          }
          // Distinct colours on the surface: a one-colour picture cannot pass.
          const hues = new Set();
          for (let i = 0; i < px.length; i += 4) if (!BACKGROUND.every((b, k) => px[i + k] === b)) hues.add(`${px[i] >> 4},${px[i + 1] >> 4},${px[i + 2] >> 4}`);
          t.diagnostic(`${B.name} ${file} view ${view}${query}: mask ${(100 * c.mask).toFixed(2)} %, colour within 8/255 on ${(100 * c.colour).toFixed(2)} % of ${c.hits} hits (worst ${c.worst}); value equal on ${(100 * same / both).toFixed(2)} % of ${both} pixels; ${hues.size} colours`);
          assert.ok(c.hits > 500 && hues.size > 20, `${c.hits} hits, ${hues.size} colours`);
          assert.ok(c.mask >= 0.995, `mask agreement ${c.mask}`);
          assert.ok(c.colour >= 0.99, `colour agreement ${c.colour}`);
          assert.ok(same >= 0.99 * both && both > 500, `values agree on ${same} of ${both}`);
        }
        // The page's controls: the map menu and the range's ends give isogrid render's --cmap and
        // --clim; the readout shows the value the native value AOV has under the pointer.
        const { page, outcome, stats } = await open(server.url, `src=/colored.cgc&view=1&size=${SIZE.join('x')}`);
        assert.equal(outcome, 'ready', stats.message);
        const shownPanels = () => page.evaluate(() => ['colour', 'labels'].filter((id) => getComputedStyle(document.getElementById(id)).display !== 'none'));
        assert.deepEqual(await shownPanels(), ['colour'], 'a coloured grid shows the colour controls only');
        await page.select('#cmap', 'magma');
        for (const [id, v] of [['#clim-lo', clim[0]], ['#clim-hi', clim[1]]]) {
          await page.$eval(id, (el, v) => {
            el.value = String(v);
            el.dispatchEvent(new Event('change'));
          }, v);
        }
        await page.evaluate(() => window.isogrid.frames(1));
        const px = Buffer.from(await page.evaluate(() => window.isogrid.pixels()), 'base64');
        const native = nativeRender(colored, 1, ['--cmap', 'magma', '--clim', clim.join(',')], 'value');
        const c = compare(px, native.png);
        t.diagnostic(`${B.name} coloured through the controls (magma, ${clim}): colour within 8/255 on ${(100 * c.colour).toFixed(2)} % of ${c.hits} hits`);
        assert.ok(c.mask >= 0.995 && c.colour >= 0.99, JSON.stringify(c));
        const [w] = SIZE;
        const at = (SIZE[1] / 2) * w + w / 2;
        assert.ok(!Number.isNaN(native.aov[at]), 'the centre pixel shows the surface');
        const box = await page.$eval('#canvas', (el) => { const r = el.getBoundingClientRect(); return [r.left, r.top, r.width / el.width]; });
        await page.mouse.move(box[0] + (at % w + 0.5) * box[2], box[1] + (Math.floor(at / w) + 0.5) * box[2]);
        await page.waitForFunction(() => document.getElementById('readout').textContent !== '');
        const shown = await page.$eval('#readout', (el) => el.textContent);
        // The pointer's position is rounded to whole CSS pixels: the pixel or one of its neighbours.
        const near = [-1, 0, 1].flatMap((dy) => [-1, 0, 1].map((dx) => native.aov[at + dy * w + dx]));
        const value = Number(shown.replace('value ', ''));
        assert.ok(near.some((v) => Math.abs(value - v) <= 1e-4 * Math.abs(v) + 1e-6), `readout ${shown}, native ${near.join(' ')}`);
        await page.close();
      });
      await t.test('coloured by an attribute in small pages: the codes are paged with the cells, pixels and values as unpaged', async () => {
        const h = parseCgc(coloredBytes).header;
        // Pages of about a 64th of the records buffers (records, then codes: records bytes +
        // 2 per cell) and instance lists, cut at cluster ends, against the one page the file
        // takes unpaged; the pictures are checked against the native value AOV too, not only
        // against each other.
        const pageBytes = Math.ceil((h.activeCells * Math.max(h.precisionBits + 2, 4)) / 64);
        const native = nativeRender(colored, 2, [], 'value');
        const range = parseCgc(coloredBytes).attribute.info.range;
        const read = async (query) => {
          const { page, outcome, stats } = await open(server.url, `src=/colored.cgc&view=2&size=${SIZE.join('x')}${query}`);
          assert.equal(outcome, 'ready', stats.message);
          const px = Buffer.from(await page.evaluate(() => window.isogrid.pixels()), 'base64');
          const values = new Uint32Array(new Uint8Array(Buffer.from(await page.evaluate(() => window.isogrid.values()), 'base64')).buffer);
          await page.close();
          return { px, values, stats };
        };
        // The compute raster sums EWA normals in integers, so its pictures match exactly; the
        // hardware raster blends them in f16 in the order the expansion listed the cells (per
        // page), so shading may move by a level or two there.
        for (const [query, tolerance] of [['&raster=compute', 0], ['&raster=hardware&ewa=0', 0], ['&raster=hardware', 2]]) {
          const one = await read(query);
          const paged = await read(`${query}&pagebytes=${pageBytes}`);
          const firsts = paged.stats.pageFirstRecords;
          assert.ok(firsts.length >= 3 && firsts.length > one.stats.pages, `${firsts.length} pages (${one.stats.pages} unpaged)`);
          assert.ok(firsts.some((f) => f % 2 === 1), `a page starts at an odd record (mid-word): ${firsts}`);
          // Pages are sized by a guess at what remains and shrunk to their clusters when full: the
          // pages hold what one page holds, plus each page's uniforms and arguments (100 bytes)
          // and the rounding of its buffers to words.
          assert.ok(paged.stats.pageBufferBytes <= one.stats.pageBufferBytes + 128 * firsts.length, `page buffers of ${paged.stats.pageBufferBytes} bytes in ${firsts.length} pages, ${one.stats.pageBufferBytes} in one`);
          let hits = 0;
          let valueDiffs = 0;
          let both = 0;
          let asNative = 0;
          const f32 = new Float32Array(paged.values.buffer);
          for (let i = 0; i < one.values.length; i++) {
            const nan = (v) => (v & 0x7fffffff) > 0x7f800000;
            if (!nan(one.values[i])) hits++;
            if (one.values[i] !== paged.values[i] && !(nan(one.values[i]) && nan(paged.values[i]))) valueDiffs++;
            if (nan(paged.values[i]) || Number.isNaN(native.aov[i])) continue;
            both++;
            if (Math.abs(f32[i] - native.aov[i]) <= 1e-5 * (range[1] - range[0])) asNative++;
          }
          let worst = 0;
          for (let i = 0; i < one.px.length; i++) worst = Math.max(worst, Math.abs(one.px[i] - paged.px[i]));
          const hues = new Set();
          for (let i = 0; i < one.px.length; i += 4) if (!BACKGROUND.every((b, k) => one.px[i + k] === b)) hues.add(`${one.px[i] >> 4},${one.px[i + 1] >> 4},${one.px[i + 2] >> 4}`);
          t.diagnostic(`${B.name} colored.cgc${query}: ${firsts.length} pages of at most ${pageBytes} bytes (first records ${firsts.join(' ')}) against ${one.stats.pages} (first records ${one.stats.pageFirstRecords.join(' ')}): ${valueDiffs} of ${hits} hit values differ, colours by at most ${worst}; values as natively on ${asNative} of ${both}; ${hues.size} colours`);
          assert.ok(hits > 500 && hues.size > 20, `${hits} hits, ${hues.size} colours`);
          assert.ok(asNative >= 0.99 * both && both > 500, `values as natively on ${asNative} of ${both}`);
          assert.equal(valueDiffs, 0, 'values differ');
          assert.ok(worst <= tolerance, `colours differ by ${worst}`);
        }
      });
      await t.test('label grid cut open by a clip plane: where labels touch, the label the ray enters', async () => {
        // Inside a cut-open label its surface and its neighbour's coincide on their boundary; the
        // face the ray enters wins (FLAG_LABELS), as in every native renderer. The label under each
        // pixel (its cluster's) against a march of the label volume, away from label edges.
        const f = parseCgc(labelBytes);
        for (const [view, clip, axis, fraction, flip] of [[2, 'z:0.5', 2, 0.5, false], [2, 'y:0.5', 1, 0.5, false], [1, 'z:0.45', 2, 0.45, false]]) {
          const { page, outcome, stats } = await open(server.url, `src=/labels.cgc&view=${view}&size=${SIZE.join('x')}&clip=${clip}`);
          assert.equal(outcome, 'ready', stats.message);
          const ids = new Uint32Array(Buffer.from(await page.evaluate(() => window.isogrid.clusters()), 'base64').buffer.slice(0));
          await page.close();
          const shown = [...ids].map((k) => (k === 0xffffffff ? -1 : Number(f.labels.table[f.labels.clusterLabels[k]].value)));
          const ref = clippedLabels(48, view, axis, 47 * fraction, flip);
          const [w, h] = SIZE;
          let inner = 0;
          let agree = 0;
          const seen = new Set();
          for (let i = 0; i < w * h; i++) {
            const [x, y] = [i % w, Math.floor(i / w)];
            if (ref[i] < 0 || x < 1 || y < 1 || x >= w - 1 || y >= h - 1) continue;
            if ([i - 1, i + 1, i - w, i + w].some((j) => ref[j] !== ref[i])) continue;
            inner++;
            seen.add(ref[i]);
            if (shown[i] === ref[i]) agree++;
          }
          t.diagnostic(`${B.name} labels view ${view} clip ${clip}: ${agree} of ${inner} pixels inside labels ${[...seen].join(', ')} show the marched label`);
          assert.ok(inner > 700 && seen.size >= 2, `${inner} pixels, labels ${[...seen]}`);
          assert.ok(agree >= 0.995 * inner, `${agree} of ${inner}`);
        }
      });
      await t.test('label grid: label colours as isogrid render; hiding a label changes its pixels only; a click names the label', async () => {
        const size = SIZE.join('x');
        const f = parseCgc(labelBytes);
        const name = (i) => f.labels.table[i].name;
        for (const view of [1, 2]) {
          const { page, outcome, stats } = await open(server.url, `src=/labels.cgc&view=${view}&size=${size}`);
          assert.equal(outcome, 'ready', stats.message);
          const px = Buffer.from(await page.evaluate(() => window.isogrid.pixels()), 'base64');
          const native = nativeRender(labelled, view, [], 'cluster');
          const c = compare(px, native.png);
          // The label each native pixel shows, from its cluster.
          const labelOf = [...native.aov].map((k) => (k === 0xffffffff ? -1 : f.labels.clusterLabels[k]));
          const counts = f.labels.table.map((_, i) => labelOf.filter((l) => l === i).length);
          t.diagnostic(`${B.name} labels view ${view}: mask ${(100 * c.mask).toFixed(2)} %, colour within 8/255 on ${(100 * c.colour).toFixed(2)} % of ${c.hits} hits (worst ${c.worst}); pixels per label ${counts.join(', ')}`);
          assert.ok(c.mask >= 0.995, `mask agreement ${c.mask}`);
          // Each label's surface closes its own label, so in cells where labels meet the outer
          // surface two labels' surfaces coincide, with opposite normals; their EWA splats nearly
          // cancel there and the shading follows the summation order, which differs between the
          // browser's blending and the native raster: 97 % with EWA, 99 % without.
          assert.ok(c.colour >= 0.97, `colour agreement ${c.colour}`);
          {
            const { page: plainPage, outcome: o2, stats: s2 } = await open(server.url, `src=/labels.cgc&view=${view}&size=${size}&ewa=0`);
            assert.equal(o2, 'ready', s2.message);
            const plainPx = Buffer.from(await plainPage.evaluate(() => window.isogrid.pixels()), 'base64');
            await plainPage.close();
            const c2 = compare(plainPx, nativeRender(labelled, view, ['--mode', 'cgc-noewa']));
            t.diagnostic(`${B.name} labels view ${view} without EWA: mask ${(100 * c2.mask).toFixed(2)} %, colour within 8/255 on ${(100 * c2.colour).toFixed(2)} % of ${c2.hits} hits (worst ${c2.worst})`);
            assert.ok(c2.mask >= 0.995 && c2.colour >= 0.99, JSON.stringify(c2));
          }
          assert.ok(counts.filter((n) => n > 100).length >= 3, `labels on screen: ${counts}`);
          // Hide each label seen in turn (?hide=V): its pixels change, the others stay, away from
          // its silhouette (pixels next to one of its pixels may be covered by its surface's edge).
          const [w, h] = SIZE;
          for (const [i] of counts.map((n, i) => [i, n]).filter(([, n]) => n > 100)) {
            const value = labelText(f.labels.table[i].value, f.header.scalarType);
            const hidden = await open(server.url, `src=/labels.cgc&view=${view}&size=${size}&hide=${value}`);
            assert.equal(hidden.outcome, 'ready', hidden.stats.message);
            const hpx = Buffer.from(await hidden.page.evaluate(() => window.isogrid.pixels()), 'base64');
            await hidden.page.close();
            const near = (p) => {
              const [x, y] = [p % w, Math.floor(p / w)];
              for (let dy = -1; dy <= 1; dy++) for (let dx = -1; dx <= 1; dx++) {
                const [u, v] = [x + dx, y + dy];
                if (u >= 0 && v >= 0 && u < w && v < h && labelOf[v * w + u] === i) return true;
              }
              return false;
            };
            let own = 0, ownChanged = 0, other = 0, otherSame = 0;
            for (let p = 0; p < w * h; p++) {
              const d = Math.max(...[0, 1, 2].map((k) => Math.abs(hpx[4 * p + k] - px[4 * p + k])));
              if (labelOf[p] === i) {
                own++;
                if (d > 8) ownChanged++;
              } else if (!near(p)) {
                other++;
                if (d <= 8) otherSame++;
              }
            }
            t.diagnostic(`${B.name} view ${view} hide ${name(i)}: ${ownChanged} of its ${own} pixels changed, ${otherSame} of ${other} other pixels unchanged`);
            assert.ok(ownChanged >= 0.99 * own, `hiding ${name(i)}: ${ownChanged} of ${own} changed`);
            assert.ok(otherSame >= 0.995 * other, `hiding ${name(i)}: ${otherSame} of ${other} others unchanged`);
          }
          // Clicking names the label the native image shows there; hide all and show all.
          const at = labelOf.findIndex((l, p) => l >= 0 && p % w > 2 && labelOf[p + 1] === l && labelOf[p - 1] === l && labelOf[p + w] === l && labelOf[p - w] === l);
          const [x, y] = [at % w, Math.floor(at / w)];
          const box = await page.$eval('#canvas', (el) => { const r = el.getBoundingClientRect(); return [r.left, r.top, r.width / el.width]; });
          await page.mouse.click(box[0] + (x + 0.5) * box[2], box[1] + (y + 0.5) * box[2]);
          await page.waitForFunction(() => document.getElementById('picked').textContent !== '');
          assert.equal(await page.$eval('#picked', (el) => el.textContent), name(labelOf[at]));
          assert.deepEqual(
            await page.evaluate(() => ['colour', 'labels'].filter((id) => getComputedStyle(document.getElementById(id)).display !== 'none')),
            ['labels'],
            'a label grid shows the label list only',
          );
          // The list: every label with its swatch, and a search narrows it.
          const rows = () => page.$$eval('#label-list li', (li) => li.map((l) => [l.children[1].style.background, l.children[2].textContent]));
          assert.deepEqual(await rows(), f.labels.table.map((l) => [`rgb(${l.rgba.slice(0, 3).join(', ')})`, l.name]));
          await page.type('#label-search', name(3));
          assert.deepEqual((await rows()).map(([, n]) => n), [name(3)]);
          // Its name frames it: the picture's centre then shows that label, and Fit goes back.
          await page.click('#label-list .name');
          await page.evaluate(() => window.isogrid.frames(1));
          const centre = await page.evaluate(([w, h]) => window.isogrid.pick(w >> 1, h >> 1), SIZE);
          assert.equal(centre?.label, name(3));
          await page.click('#fit');
          await page.click('#labels-hide');
          await page.evaluate(() => window.isogrid.frames(1));
          const none = Buffer.from(await page.evaluate(() => window.isogrid.pixels()), 'base64');
          assert.ok(compare(none, none).hits === 0, 'hide all leaves surface on screen');
          await page.click('#labels-show');
          await page.evaluate(() => window.isogrid.frames(1));
          const again = Buffer.from(await page.evaluate(() => window.isogrid.pixels()), 'base64');
          assert.ok(compare(again, px).colour >= 0.999, 'show all does not give the picture back');
          await page.close();
        }
        {
          // At phone width the list starts collapsed to its toggle, which opens and closes it.
          const page = await browser.newPage();
          page.on('console', (m) => m.type() === 'error' && errors.push(m.text()));
          await page.setViewport({ width: 390, height: 844 });
          await page.goto(`${server.url}/index.html?src=/labels.cgc`);
          await page.evaluate(() => window.isogrid.ready);
          const listShown = () => page.$eval('#label-list', (el) => getComputedStyle(el).display !== 'none');
          assert.equal(await listShown(), false, 'the label list covers the picture at phone width');
          assert.equal(await page.$eval('#labels-toggle', (el) => el.textContent), `Labels (${f.labels.table.length})`);
          await page.click('#labels-toggle');
          assert.equal(await listShown(), true, 'the toggle does not open the label list');
          await page.click('#labels-toggle');
          assert.equal(await listShown(), false, 'the toggle does not close the label list');
          await page.close();
        }
      });
      await t.test('damaged, truncated and version-mismatch files show their message', async () => {
        const expect = {
          'damaged.cgc': /^damaged\.cgc: cells section checksum mismatch \(the data is damaged\)$/,
          'truncated.cgc': /^truncated\.cgc: .*does not fit the 7\d+-byte file \(truncated\?\)$/,
          'future.cgc': /^future\.cgc: format version 9; this viewer reads versions 1 and 2$/,
          'badlabels.cgc': /^badlabels\.cgc: cluster 0 has label 4 of 4$/,
          'badattribute.cgc': /^badattribute\.cgc: cell attribute of 12 bits per value$/,
        };
        for (const [name, re] of Object.entries(expect)) {
          const { outcome, stats } = await open(server.url, `src=/${name}`);
          assert.match(stats.message, re);
          assert.equal(outcome, `error: ${stats.message}`);
        }
      });
      await t.test('an empty surface loads and says why, in the words of isogrid info', async () => {
        const empty = emptyFiles();
        assert.equal(empty.length, 2);
        for (const [name, , note] of empty) {
          const { page, outcome, stats } = await open(server.url, `src=/${name}`);
          assert.equal(outcome, 'ready', stats.message);
          assert.equal(stats.message, `${name}: ${note}`);
          assert.equal(await page.$eval('#message', (m) => m.className), 'notice');
          await page.close();
        }
      });
      await t.test('axes that mirror the world: the picture is that of the same world stored the other way round, from the .cgc and its packed form', async () => {
        // placed24 runs left along its first axis (LAS); its twin holds the same world running
        // right (RAS), so the twin's native picture is the world as it lies.
        const reference = nativeRender(placedSphereFile(24, true), 1);
        for (const name of ['placed24.cgc', 'placed24.cgcz']) {
          const { page, outcome, stats } = await open(server.url, `src=/${name}&view=1&size=${SIZE.join('x')}`);
          assert.equal(outcome, 'ready', stats.message);
          const c = compare(Buffer.from(await page.evaluate(() => window.isogrid.pixels()), 'base64'), reference);
          t.diagnostic(`${B.name} ${name}: mask ${(100 * c.mask).toFixed(2)} %, colour within 8/255 on ${(100 * c.colour).toFixed(2)} % of ${c.hits} hits`);
          assert.ok(c.hits > 500 && c.mask >= 0.995 && c.colour >= 0.99, JSON.stringify(c));
          await page.close();
        }
      });
      await t.test('packed files (.cgcz): the picture of their .cgc from their own bytes; damage named', async () => {
        // The label grid's tolerance is its .cgc's (the label grid test above).
        for (const [name, file, packed, colour] of [['sphere48', sphere, spherePacked, 0.99], ['colored', colored, coloredPacked, 0.99], ['labels', labelled, labelPacked, 0.97]]) {
          const { page, outcome, stats } = await open(server.url, `src=/${name}.cgcz&view=2&size=${SIZE.join('x')}`);
          assert.equal(outcome, 'ready', stats.message);
          assert.equal(stats.downloaded, packed.length, 'bytes downloaded');
          assert.equal(stats.rebuildThread, 'worker', 'where the packed file was rebuilt');
          const c = compare(Buffer.from(await page.evaluate(() => window.isogrid.pixels()), 'base64'), nativeRender(file, 2));
          t.diagnostic(`${B.name} ${name}.cgcz (${packed.length} bytes): mask ${(100 * c.mask).toFixed(2)} %, colour within 8/255 on ${(100 * c.colour).toFixed(2)} % of ${c.hits} hits`);
          assert.ok(c.hits > 500 && c.mask >= 0.995 && c.colour >= colour, JSON.stringify(c));
          await page.close();
        }
        // Where the page forbids workers, rebuilt on the page's thread: the same picture.
        {
          const { page, outcome, stats } = await open(noWorkers.url, `src=/sphere48.cgcz&view=2&size=${SIZE.join('x')}`);
          assert.equal(outcome, 'ready', stats.message);
          assert.equal(stats.rebuildThread, 'page', 'where the packed file was rebuilt without workers');
          assert.equal(stats.downloaded, spherePacked.length, 'bytes downloaded');
          const c = compare(Buffer.from(await page.evaluate(() => window.isogrid.pixels()), 'base64'), nativeRender(sphere, 2));
          assert.ok(c.hits > 500 && c.mask >= 0.995 && c.colour >= 0.99, JSON.stringify(c));
          await page.close();
        }
        for (const [name, re] of Object.entries({
          'damaged.cgcz': /^damaged\.cgcz: .*damaged/,
          'truncated.cgcz': /^truncated\.cgcz: the packed file ends after \d+ of its \d+ bytes \(truncated\?\)$/,
        })) {
          const { outcome, stats } = await open(server.url, `src=/${name}`);
          assert.match(stats.message, re);
          assert.equal(outcome, `error: ${stats.message}`);
        }
      });
      await t.test('a local file through the file input (as a drop): a .cgc and a packed .cgcz', async () => {
        for (const file of [sphere, packedFile(sphere)]) {
          const page = await browser.newPage();
          page.on('console', (m) => m.type() === 'error' && errors.push(m.text()));
          await page.goto(`${server.url}/index.html?view=2&size=${SIZE.join('x')}`);
          await (await page.$('#file')).uploadFile(file);
          const outcome = await page.evaluate(() => window.isogrid.ready.then(() => 'ready', (e) => `error: ${e.message}`));
          const stats = await page.evaluate(() => ({ ...window.isogrid.stats, message: document.getElementById('message').textContent }));
          assert.equal(outcome, 'ready', stats.message);
          assert.equal(stats.name, file.split('/').pop());
          if (file.endsWith('.cgcz')) assert.equal(stats.rebuildThread, 'worker', 'where the dropped packed file was rebuilt');
          const c = compare(Buffer.from(await page.evaluate(() => window.isogrid.pixels()), 'base64'), nativeRender(sphere, 2));
          t.diagnostic(`${B.name} ${stats.name} opened locally: mask ${(100 * c.mask).toFixed(2)} %, colour within 8/255 on ${(100 * c.colour).toFixed(2)} %`);
          assert.ok(c.hits > 500 && c.mask >= 0.995 && c.colour >= 0.99, JSON.stringify(c));
          await page.close();
        }
      });
      await t.test('range loading: first frame before the last byte, each byte requested once', async () => {
        const { outcome, stats } = await open(slow.url, 'src=/sphere48.cgc&size=64x48');
        assert.equal(outcome, 'ready', stats.message);
        const ranges = slow.log.filter((r) => r.path === '/sphere48.cgc').sort((a, b) => a.start - b.start);
        let at = 0;
        for (const r of ranges) {
          assert.equal(r.start, at, 'a byte range requested twice or never');
          at = r.end;
        }
        assert.equal(at, sphereBytes.length);
        assert.ok(stats.firstFrameBytes < sphereBytes.length, `first frame after ${stats.firstFrameBytes} of ${sphereBytes.length} bytes`);
        // Its clusters came in pieces (a frame before the last byte), yet it is cut into pages as
        // the whole file: one, as it fits a binding (each page costs every pass a dispatch).
        assert.equal(stats.pages, 1, `${stats.pages} pages`);
        t.diagnostic(`${B.name}: first frame after ${stats.firstFrameBytes} of ${sphereBytes.length} bytes, ${ranges.length} requests`);
        // With an attribute: its values stream with the cells they colour, so the first frame
        // still comes before the last byte.
        const coloured = await open(slow.url, 'src=/colored.cgc&size=64x48');
        assert.equal(coloured.outcome, 'ready', coloured.stats.message);
        assert.ok(coloured.stats.firstFrameBytes < coloredBytes.length, `first coloured frame after ${coloured.stats.firstFrameBytes} of ${coloredBytes.length} bytes`);
        assert.equal(coloured.stats.pages, 1, `${coloured.stats.pages} pages`);
        t.diagnostic(`${B.name}: coloured file, first frame after ${coloured.stats.firstFrameBytes} of ${coloredBytes.length} bytes`);
      });
      await t.test('through isogrid serve, throttled to 0.125 Mbit/s: the packed form; by ranges, first frame before the last byte, ranges cover the file once', async (st) => {
        if (B.name !== 'chromium') {
          st.skip('download throttling needs the DevTools protocol (Chromium)');
          return;
        }
        const child = spawn(bin, ['serve', sphere, '--port', '0'], { stdio: ['ignore', 'pipe', 'inherit'] });
        try {
          const line = await new Promise((resolve, reject) => {
            createInterface({ input: child.stdout }).once('line', resolve);
            child.once('exit', (code) => reject(new Error(`isogrid serve exited with ${code} before printing its URL`)));
          });
          // The printed URL opens the packed form; ?src=/NAME.cgc reads the file by ranges.
          const url = line.split(/\s+/).find((w) => w.startsWith('http://'));
          assert.match(url, /\/\?src=\/sphere48\.cgcz$/);
          const packedPage = await browser.newPage();
          await packedPage.emulateNetworkConditions({ download: 0.125e6 / 8, upload: 0.125e6 / 8, latency: 20 });
          await packedPage.goto(`${url}&size=64x48`);
          assert.equal(await packedPage.evaluate(() => window.isogrid.ready.then(() => 'ready', (e) => e.message)), 'ready');
          const packedStats = await packedPage.evaluate(() => window.isogrid.stats);
          assert.equal(packedStats.downloaded, spherePacked.length);
          st.diagnostic(`isogrid serve at 0.125 Mbit/s, packed: ${spherePacked.length} bytes, first frame shown at ${packedStats.firstFrameAt.toFixed(0)} ms, complete picture at ${packedStats.readyAt.toFixed(0)} ms`);
          await packedPage.close();
          const page = await browser.newPage();
          const ranges = [];
          page.on('request', (r) => {
            const m = /bytes=(\d+)-(\d+)/.exec(r.headers().range || '');
            if (m) ranges.push([Number(m[1]), Number(m[2]) + 1]);
          });
          await page.emulateNetworkConditions({ download: 0.125e6 / 8, upload: 0.125e6 / 8, latency: 20 });
          await page.goto(`${url.replace(/\.cgcz$/, '.cgc')}&size=64x48`);
          const outcome = await page.evaluate(() => window.isogrid.ready.then(() => 'ready', (e) => e.message));
          assert.equal(outcome, 'ready');
          const stats = await page.evaluate(() => window.isogrid.stats);
          ranges.sort((a, b) => a[0] - b[0]);
          let at = 0;
          for (const [s0, e] of ranges) {
            assert.equal(s0, at, 'a byte range requested twice or never');
            at = Math.min(e, sphereBytes.length);
          }
          assert.equal(at, sphereBytes.length);
          // Shown (read back into the page) before the last byte had arrived.
          assert.ok(stats.firstFrameBytes < sphereBytes.length && stats.firstFrameAt < stats.completeAt, JSON.stringify(stats));
          st.diagnostic(`isogrid serve at 0.125 Mbit/s: first frame shown at ${stats.firstFrameAt.toFixed(0)} ms (after ${stats.firstFrameBytes} of ${sphereBytes.length} bytes), last byte at ${stats.completeAt.toFixed(0)} ms, complete picture at ${stats.readyAt.toFixed(0)} ms`);
          await page.close();
        } finally {
          child.kill();
        }
      });
      await t.test('a server without Range support: one whole download and a notice', async () => {
        plain.log.length = 0;
        const { outcome, stats } = await open(plain.url, 'src=/sphere48.cgc&size=64x48');
        assert.equal(outcome, 'ready', stats.message);
        assert.match(stats.message, /does not support range requests/);
        assert.equal(plain.log.filter((r) => r.path === '/sphere48.cgc').length, 1);
      });
      await t.test('without WebGPU the page says which browsers and flags work', async (st) => {
        if (B.name !== 'chromium') {
          st.skip('Chromium without --enable-unsafe-webgpu is the browser here that has no adapter');
          return;
        }
        const plainChromium = await puppeteer.launch({ executablePath: B.path, headless: true, browser: 'chrome', args: ['--no-sandbox', '--headless=new'] });
        try {
          const page = await plainChromium.newPage();
          await page.goto(`${server.url}/index.html?src=/tiny.cgc`);
          const outcome = await page.evaluate(() => window.isogrid.ready.then(() => 'ready', (e) => e.message));
          assert.match(outcome, /no WebGPU.*Chrome.*--enable-unsafe-webgpu.*Firefox.*dom\.webgpu\.enabled/);
          assert.equal(await page.evaluate(() => document.getElementById('message').textContent), outcome);
        } finally {
          await plainChromium.close();
        }
      });
      assert.deepEqual(errors.filter((e) => !/checksum|truncated|version|Failed to load resource|Content Security Policy/.test(e)), [], 'console errors');
    } finally {
      await browser.close();
      await server.close();
      await plain.close();
      await slow.close();
      await noWorkers.close();
    }
  });
}
