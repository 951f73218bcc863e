// The viewer page: WebGPU set-up, loading (`?src=URL` or a dropped file), camera controls, the
// facts panel, and `window.isogrid` for tests: `ready` settles after the first complete frame of
// the whole file (rejects with the page's error message), `pixels()` gives the colour target.
// URL parameters: `src`, `view=1|2` and `size=WxH` (the camera and canvas of
// `isogrid render --view N --size WxH`), `clip=[-]x|y|z[:F]` (a clip plane across that axis at
// fraction F of the grid's extent, 0.5 by default, cutting away the larger coordinates, or the
// smaller ones with `-`); colour: `cmap=NAME` and `clim=LO,HI` (the attribute's colour map and
// range; default viridis over the stored range), `hide=V,...` (label values hidden at the start),
// `ewa=0` (no EWA normal splats: `isogrid render --mode cgc-noewa`), `raster=compute|hardware`
// (the cell raster, `isogrid render --cell-raster`; by default chosen per frame as natively),
// `pagebytes=N` (pages of at most N bytes instead of the storage binding limit: tests paging).

import {
  AttributeInfo, CgcError, CgcHeader, CodeMapping, GridLabels, codeMapping, codesOf, directionsMirror, emptySurfaceNote, labelText, worldBounds,
} from './cgc.js';
import {
  COLOR_LABELS, COLOR_RECORDS, MAP_NAMES, labelColorWords, colorUniforms, defaultClim, hiddenClusters, mapTable, parseClim,
} from './colors.js';
import { Camera, ClipPlane, orbit, pan, presetCamera, zoom } from './camera.js';
import { blobSource, ByteSource, streamCgc, urlSource, withHeadStarted } from './loader.js';
import { isPackedName } from './packed.js';
import { PackedSource, packedSourceOffThread } from './packed-client.js';
import { CellRaster, COLOR_FORMAT, Renderer } from './renderer.js';

const $ = <T extends HTMLElement>(id: string) => document.getElementById(id) as T;
const canvas = $<HTMLCanvasElement>('canvas');
const message = $('message');
const params = new URLSearchParams(location.search);

interface IsogridApi {
  ready: Promise<void>;
  pixels(): Promise<string>;
  /**
   * Draws `n` more frames of the current view one after another: median wall ms (with the
   * read-back), JS ms to encode and submit, GPU ms of the frame and of each pass (timestamps).
   * `fresh`: each frame starts from "every cluster visible", as the first frame of a view does.
   */
  frames(n: number, fresh?: boolean): Promise<{ wallMs: number; encodeMs: number; gpuMs: number | null; passMs: Record<string, number> | null; cells: { full: number; probe: number; new: number } }>;
  /** The value target of the last frame: f32 rows top to bottom, base64 (NaN: miss or no value). */
  values(): Promise<string>;
  /** The hit cluster under each pixel, u32 (0xffffffff on a miss), base64. */
  clusters(): Promise<string>;
  /** What pixel (x, y) of the last frame shows: cluster, record, value, and the label's name. */
  pick(x: number, y: number): Promise<{ cluster: number; record: number; value: number; label: string | null } | null>;
  stats: Record<string, unknown>;
}
declare global {
  interface Window {
    isogrid: IsogridApi;
  }
}

let settle!: { resolve: () => void; reject: (e: Error) => void };
/** Settles when the first frame with clusters is started (or loading fails): the loader's gate. */
const firstDrawn = (() => {
  let resolve!: () => void;
  const promise = new Promise<void>((r) => (resolve = r));
  return { promise, resolve };
})();
const ready = new Promise<void>((resolve, reject) => (settle = { resolve, reject }));
ready.catch(() => {}); // reported in the page; a test reads the rejection itself
const stats: Record<string, unknown> = { frameLog: [] };
/** A target's bytes as base64, for `window.isogrid`'s readers (puppeteer passes strings). */
function base64(bytes: Uint8Array): string {
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  return btoa(s);
}
window.isogrid = {
  ready,
  stats,
  async pixels() {
    if (!renderer) throw new Error('nothing rendered');
    return base64(await renderer.readPixels());
  },
  async values() {
    return base64(new Uint8Array((await renderer!.readValues()).buffer));
  },
  async clusters() {
    return base64(new Uint8Array((await renderer!.readClusters()).buffer));
  },
  async pick(x, y) {
    const hit = await renderer!.readPixel(x, y);
    return hit && { ...hit, label: labels ? labelName(labels.clusterLabels[hit.cluster]) : null };
  },
  async frames(n, fresh = false) {
    const median = (v: number[]) => v.sort((a, b) => a - b)[Math.floor(v.length / 2)];
    const wall: number[] = [];
    const encode: number[] = [];
    const gpu: number[] = [];
    const passes: Record<string, number[]> = {};
    for (let i = 0; i < n; i++) {
      if (fresh) renderer!.resetVisibility();
      const t0 = performance.now();
      renderer!.render(camera!, null, clipPlane());
      encode.push(renderer!.lastEncodeMs);
      const timings = renderer!.lastTimed;
      await renderer!.readPixels();
      wall.push(performance.now() - t0);
      // This frame's timestamps (none when the query set was still busy with an earlier frame's).
      if (timings) {
        await timings;
        if (renderer!.lastGpuMs != null) gpu.push(renderer!.lastGpuMs);
        for (const [k, v] of Object.entries(renderer!.lastPassMs ?? {})) (passes[k] ??= []).push(v);
      }
    }
    const passMs = Object.keys(passes).length ? Object.fromEntries(Object.entries(passes).map(([k, v]) => [k, median(v)])) : null;
    return { wallMs: median(wall), encodeMs: median(encode), gpuMs: gpu.length ? median(gpu) : null, passMs, cells: await renderer!.listedCells() };
  },
};

function showMessage(text: string, notice = false): void {
  message.textContent = text;
  message.className = notice ? 'notice' : '';
  message.style.display = 'block';
}

function fail(e: unknown, name: string): void {
  firstDrawn.resolve();
  const text = e instanceof CgcError ? `${name}: ${e.message}` : e instanceof Error ? e.message : String(e);
  showMessage(text);
  stats.error = text;
  settle.reject(new Error(text));
}

function parseSize(s: string | null): [number, number] | null {
  const m = s ? /^(\d+)x(\d+)$/.exec(s) : null;
  if (!m) return null;
  const [w, h] = [Number(m[1]), Number(m[2])];
  return w > 0 && h > 0 && w <= 8192 && h <= 8192 ? [w, h] : null;
}

function parseClip(s: string | null): { axis: number | null; fraction: number; flip: boolean } {
  const m = s ? /^(-?)([xyz])(?::([0-9.]+))?$/.exec(s) : null;
  const fraction = m?.[3] !== undefined ? Number(m[3]) : 0.5;
  if (!m || !(fraction >= 0 && fraction <= 1)) return { axis: null, fraction: 0.5, flip: false };
  return { axis: 'xyz'.indexOf(m[2]), fraction, flip: m[1] === '-' };
}

/** The clip plane in world space (index × spacing) from the control and the grid's bounds. */
function clipPlane(): ClipPlane | null {
  if (clipControl.axis === null || !header) return null;
  const [lo, hi] = worldBounds(header);
  const a = clipControl.axis;
  return { axis: a, at: lo[a] + clipControl.fraction * (hi[a] - lo[a]), flip: clipControl.flip };
}

// Held for the page's life: a collected adapter can take the device's instance with it.
let adapter: GPUAdapter | null = null;
let device: GPUDevice | null = null;
let fallbackAdapter = false;
let context: GPUCanvasContext | null = null;
/**
 * Where the frame is shown on a fallback (software) adapter: a 2D canvas the colour target is
 * read back into. Headless Chromium's SwiftShader loses its GPU instance once a WebGPU canvas is
 * presented, after which no map or work-done promise settles.
 */
let context2d: CanvasRenderingContext2D | null = null;
let renderer: Renderer | null = null;
let rendererReady = false;
let header: CgcHeader | null = null;
let camera: Camera | null = null;
let view = params.get('view') === '1' ? 1 : 2;
const fixedSize = parseSize(params.get('size'));
/** `raster=compute|hardware` (`isogrid render --cell-raster`); auto by default. */
const cellRasterParam: CellRaster = params.get('raster') === 'compute' || params.get('raster') === 'hardware' ? (params.get('raster') as CellRaster) : 'auto';
/** The clip control: axis (null: no plane), position as a fraction of the extent, side. */
const clipControl = parseClip(params.get('clip'));
let complete = false;
let bytesIn = 0;

async function initGpu(): Promise<GPUDevice> {
  const noWebGpu =
    'This browser has no WebGPU. The viewer works in Chrome or Edge 113+ and Chromium (with --enable-unsafe-webgpu on Linux), ' +
    'Firefox 141+ on Windows (Firefox elsewhere with dom.webgpu.enabled and gfx.webgpu.ignore-blocklist in about:config), and Safari 26+.';
  if (!('gpu' in navigator)) throw new Error(noWebGpu);
  adapter = await navigator.gpu.requestAdapter();
  if (!adapter) throw new Error(noWebGpu);
  const features: GPUFeatureName[] = adapter.features.has('timestamp-query') ? ['timestamp-query'] : [];
  const d = await adapter.requestDevice({
    requiredFeatures: features,
    requiredLimits: {
      maxStorageBufferBindingSize: Math.min(adapter.limits.maxStorageBufferBindingSize, 128 << 20),
      maxBufferSize: Math.min(adapter.limits.maxBufferSize, 256 << 20),
      maxStorageBuffersPerShaderStage: Math.min(adapter.limits.maxStorageBuffersPerShaderStage, 10),
    },
  });
  d.addEventListener('uncapturederror', (e) => fail(new Error(`WebGPU error: ${(e as GPUUncapturedErrorEvent).error.message}`), ''));
  const info = adapter.info;
  fallbackAdapter = Boolean((info as GPUAdapterInfo & { isFallbackAdapter?: boolean })?.isFallbackAdapter ?? (adapter as GPUAdapter & { isFallbackAdapter?: boolean }).isFallbackAdapter);
  stats.adapter = info ? `${info.vendor} ${info.architecture} ${info.description}`.trim() : '';
  return d;
}

function canvasSize(): [number, number] {
  if (fixedSize) return fixedSize;
  const r = $('stage').getBoundingClientRect();
  const dpr = window.devicePixelRatio || 1;
  return [Math.max(1, Math.round(r.width * dpr)), Math.max(1, Math.round(r.height * dpr))];
}

/**
 * The current view's camera framing world box [lo, hi] (default: the grid's bounds), mirrored
 * where the grid's axes mirror its world, so that it shows the world as it lies.
 */
function resetCamera(box: [number[], number[]] | null = null): void {
  if (!header) return;
  const [w, h] = canvasSize();
  const [lo, hi] = box ?? worldBounds(header);
  camera = presetCamera(view, lo, hi, w, h, directionsMirror(header.direction));
  requestFrame();
}

/**
 * Frame pacing. At most one frame is in flight; requests while one is (data arriving, camera
 * moves) are coalesced into one frame after it. While the file loads, frames are spaced so that
 * drawing takes at most a third of the time (the gap after a frame is twice its duration), and
 * none is started when the rest of the file should arrive before it would end: on a CPU adapter
 * a frame takes seconds and shares the cores with the download, and a frame cannot be stopped,
 * so one started just before the last byte delays the complete picture by its whole duration.
 * Once every byte is in, the complete picture is drawn as soon as no frame is in flight.
 */
const LOADING_GAP = 2;
let frameTimer: ReturnType<typeof setTimeout> | null = null;
/** When the scheduled frame is due (performance.now() ms). */
let frameDue = 0;
let frameWanted = false;
/** The last frame shown: when it started and ended, and the bytes in when it started. */
let lastFrame: { start: number; end: number; bytes: number } | null = null;
/** The first frame with clusters: when it started and the bytes in then. */
let firstFrame: { start: number; bytes: number } | null = null;

function requestFrame(): void {
  frameWanted = true;
  if (drawing) return;
  const delay = frameDelay();
  if (delay === null) return; // the complete file comes first: `load` asks again
  // A frame already due no later stands; one due later (a loading gap) gives way.
  if (frameTimer !== null && frameDue <= performance.now() + delay) return;
  if (frameTimer !== null) clearTimeout(frameTimer);
  const run = () => {
    if (frameTimer !== timer) return; // run already (by the other of the two callbacks)
    clearTimeout(timer);
    frameTimer = null;
    if (!frameWanted) return;
    // Judged again when due: the rest of the file may now be about to arrive.
    const still = frameDelay();
    if (still === null) return;
    if (still > 1) requestFrame();
    else drawFrame();
  };
  const timer = setTimeout(run, delay > 0 ? delay : 100); // headless pages may not run animation frames
  frameTimer = timer;
  frameDue = performance.now() + delay;
  if (delay <= 0) requestAnimationFrame(run);
}

/** Milliseconds to wait before the next frame, or null to wait for the last byte. */
function frameDelay(): number | null {
  if (complete || !lastFrame || !header || lastFrame.bytes === 0) return 0;
  const now = performance.now();
  const duration = lastFrame.end - lastFrame.start;
  // The next frame draws about bytesIn / lastFrame.bytes times the cells of the last one.
  const expected = duration * Math.max(1, bytesIn / lastFrame.bytes);
  // The rate since the first frame: before it the loader waits for the renderer (`drawn`).
  const rate = (bytesIn - firstFrame!.bytes) / Math.max(now - firstFrame!.start, 1);
  if ((header.fileLength - bytesIn) / rate < expected) return null;
  return Math.max(0, lastFrame.end + LOADING_GAP * duration - now);
}

let drawing = false;

function drawFrame(): void {
  if (!renderer || !rendererReady || !camera || !device || (!context && !context2d)) return;
  frameWanted = false;
  if (canvas.width !== camera.width || canvas.height !== camera.height) {
    canvas.width = camera.width;
    canvas.height = camera.height;
  }
  const wasComplete = complete;
  const t0 = performance.now();
  const bytesAtStart = renderer.pageCount > 0 ? bytesIn : 0;
  const cam = camera;
  renderer.render(cam, context ? context.getCurrentTexture() : null, clipPlane());
  stats.pages = renderer.pageCount;
  stats.pageFirstRecords = renderer.pageFirstRecords;
  stats.pageBufferBytes = renderer.pageBufferBytes;
  stats.raster = renderer.lastRaster;
  stats.frames = ((stats.frames as number) || 0) + 1;
  if (!stats.firstFrameBytes && renderer.pageCount > 0) {
    // Bytes of the file on the wire: the packed ones for a .cgcz (bytesIn counts those rebuilt).
    stats.firstFrameBytes = stats.packed ? stats.downloaded : bytesIn;
    firstFrame = { start: t0, bytes: bytesIn };
    firstDrawn.resolve();
  }
  drawing = true;
  // Presented through the WebGPU canvas, or (fallback adapters) read back into a 2D canvas.
  const shown: Promise<unknown> = context
    ? device.queue.onSubmittedWorkDone()
    : renderer.readPixels().then((px) => {
        context2d!.putImageData(new ImageData(new Uint8ClampedArray(px.buffer as ArrayBuffer), cam.width, cam.height), 0, 0);
      });
  shown.then(
    () => {
      drawing = false;
      const end = performance.now();
      stats.frameMs = end - t0;
      lastFrame = { start: t0, end, bytes: bytesAtStart };
      // The frames of the load, up to the complete picture (for the benchmark).
      if (!stats.readyAt) (stats.frameLog as unknown[]).push({ at: Math.round(t0), ms: Math.round(end - t0), bytes: bytesAtStart, pages: stats.pages });
      if (!stats.firstFrameAt && (stats.pages as number) > 0) stats.firstFrameAt = end;
      showFacts();
      if (wasComplete && !stats.readyAt) {
        stats.readyAt = end;
        settle.resolve();
        renderer!.compileRest().then(() => (stats.restCompiled = true));
      }
      if (frameWanted) requestFrame();
    },
    (e) => fail(e, ''),
  );
}

function showFacts(): void {
  if (!header) return;
  const rows: [string, string][] = [
    ['file', `${stats.name} (v${header.version})`],
    ['grid', `${header.dims.join('×')} samples, ${header.precisionBits}-bit corners`],
    ['cells', header.activeCells.toLocaleString()],
    ['clusters', (header.slotCount / 16).toLocaleString()],
    ['memory', `${((header.blocks.length + header.metacells.length + header.cells.length) / 2 ** 20).toFixed(1)} MiB of grid; GPU buffers ${((renderer?.pageBufferBytes ?? 0) / 2 ** 20).toFixed(1)} MiB in ${renderer?.pageCount ?? 0} pages`],
    stats.packed
      ? ['fetched', `${((stats.downloaded as number) / 2 ** 20).toFixed(2)} MiB packed, rebuilt ${(bytesIn / 2 ** 20).toFixed(2)} of ${(header.fileLength / 2 ** 20).toFixed(2)} MiB`]
      : ['fetched', `${(bytesIn / 2 ** 20).toFixed(2)} of ${(header.fileLength / 2 ** 20).toFixed(2)} MiB`],
    ...(attribute ? [['colour by', `${attribute.name} (${attribute.range.map((v) => Number(v.toPrecision(5))).join(' to ')})`] as [string, string]] : []),
    ...(labels ? [['labels', `${labels.table.length.toLocaleString()} (${hiddenLabels.size.toLocaleString()} hidden)`] as [string, string]] : []),
    ['frame', renderer?.lastGpuMs != null ? `${renderer.lastGpuMs.toFixed(2)} ms (GPU timestamps)` : `${(stats.frameMs as number)?.toFixed(1)} ms (wall, no timestamp queries)`],
    ['cell raster', renderer?.lastRaster ?? ''],
  ];
  const table = $('facts-table');
  table.replaceChildren(
    ...rows.map(([k, v]) => {
      const tr = document.createElement('tr');
      for (const t of [k, v]) tr.appendChild(document.createElement('td')).textContent = t;
      return tr;
    }),
  );
  $('facts').hidden = false;
}

async function load(src: ByteSource): Promise<void> {
  stats.name = src.name;
  $('hint').hidden = true;
  const bar = $('progress').firstElementChild as HTMLElement;
  try {
    // The header's request goes out while the device opens.
    const given = src;
    src = withHeadStarted(src);
    device ??= await initGpu();
    stats.deviceAt = performance.now();
    if (!context && !context2d) {
      if (fallbackAdapter) {
        context2d = canvas.getContext('2d')!;
      } else {
        context = canvas.getContext('webgpu')!;
        context.configure({ device, format: COLOR_FORMAT, usage: GPUTextureUsage.RENDER_ATTACHMENT | GPUTextureUsage.COPY_DST, alphaMode: 'opaque' });
      }
      stats.presentation = context ? 'webgpu canvas' : '2d canvas (read back)';
    }
    await streamCgc(src, {
      header(h) {
        header = h;
        const [lo, hi] = worldBounds(h);
        renderer = new Renderer(device!, { precisionBits: h.precisionBits, spacing: h.spacing, isoCode: h.isoCode, bounds: [lo, hi], slotCount: h.slotCount, activeCells: h.activeCells, labelGrid: h.labels !== null }, params.get('ewa') !== '0', true, cellRasterParam, Number(params.get('pagebytes')) || undefined);
        stats.headerAt = performance.now();
        renderer.compiled.then(() => {
          rendererReady = true;
          stats.compiledAt = performance.now();
        }, (e) => fail(e, ''));
        canvas.hidden = false;
        if (!fixedSize) $('stage').classList.add('fill');
        resetCamera();
      },
      clusters(firstSlot, metacells, firstCell, cells, counts) {
        const r = renderer!;
        // Their attribute codes have arrived before them (loader.ts) and go into their pages.
        const codes = attribute ? attributeCodes.subarray(firstCell, firstCell + cells.length / header!.precisionBits) : null;
        r.compiled.then(() => {
          r.addClusters(firstSlot, metacells, firstCell, cells, counts, codes);
          requestFrame();
        });
      },
      attributeHead(info) {
        // Codes arrive before the cells they colour (loader.ts) and are paged with them.
        stats.attribute = info.name;
        attributeCodes = new Uint16Array(header!.activeCells);
        attribute = { name: info.name, range: info.range, mapping: codeMapping(info), info };
        applyColoring();
      },
      attributeValues(first, values) {
        if (attribute) attributeCodes.set(codesOf(attribute.info, values), first);
      },
      labels(l) {
        labels = l;
        stats.labels = l.table.length;
        const refused = renderer!.setColorData(labelColorWords(l), 'label colours');
        if (refused) showMessage(`${src.name}: ${refused}`, true);
        // An attribute's colours win over the labels', as in every native renderer.
        else if (!attribute) renderer!.setColoring(colorUniforms(COLOR_LABELS));
        // ?hide=V,...: label values hidden from the start.
        const hide = new Set((params.get('hide') ?? '').split(',').map((v) => v.trim()).filter(Boolean));
        l.table.forEach((label, i) => hide.has(labelText(label.value, header!.scalarType)) && hiddenLabels.add(i));
        applyHidden();
      },
      borderOutside(outside) {
        renderer!.setBorderOutside(outside);
        stats.backfaceCulling = outside;
      },
      drawn: () => firstDrawn.promise,
      progress(received, total) {
        bytesIn = received;
        stats.bytes = received;
        stats.total = total;
        bar.style.width = `${(100 * received) / total}%`;
        if (src.notice) showMessage(src.notice, true);
        showFacts();
      },
    });
    stats.completeAt = performance.now();
    // An empty surface draws nothing: say why, as the command line's note does.
    if (header && header.activeCells === 0) {
      const values = header.labels ? (labels?.table ?? []).map((l) => l.value) : null;
      showMessage(`${src.name}: ${emptySurfaceNote(header, values)}`, true);
    }
    // Where a packed file was rebuilt ('worker' or 'page'; packed-client.ts).
    if ('thread' in given) stats.rebuildThread = (given as PackedSource).thread;
    // After the clusters queued behind the compilation (promise callbacks run in order).
    await renderer!.compiled;
    complete = true;
    requestFrame();
  } catch (e) {
    fail(e, src.name);
  }
}

// Colour: an attribute's map and range, or a label grid's colours and visible labels.
const cmapParam = (params.get('cmap') ?? '').toLowerCase();
const colour = {
  map: MAP_NAMES.includes(cmapParam) ? cmapParam : MAP_NAMES[0],
  /** null: auto, the attribute's range on the surface as stored (`Coloring::default_clim`). */
  clim: parseClim(params.get('clim')),
};
let attribute: { name: string; range: [number, number]; mapping: CodeMapping; info: AttributeInfo } | null = null;
/** The attribute's 16-bit codes (one per record), as far as they have arrived. */
let attributeCodes = new Uint16Array(0);
let labels: GridLabels | null = null;
/** Label-table indices of the hidden labels. */
const hiddenLabels = new Set<number>();
const cmapSelect = $<HTMLSelectElement>('cmap');
const climLo = $<HTMLInputElement>('clim-lo');
const climHi = $<HTMLInputElement>('clim-hi');
cmapSelect.replaceChildren(...MAP_NAMES.map((n) => Object.assign(document.createElement('option'), { value: n, textContent: n })));

function applyColoring(): void {
  if (!renderer || !attribute) return;
  const clim = colour.clim ?? defaultClim(attribute.range);
  renderer.setColoring(colorUniforms(COLOR_RECORDS, { map: colour.map, clim }, attribute.mapping));
  $('colour').hidden = false;
  cmapSelect.value = colour.map;
  climLo.value = String(clim[0]);
  climHi.value = String(clim[1]);
  $('clim-auto').setAttribute('aria-pressed', String(colour.clim === null));
  // The colour bar: the map's table left to right, between the range's two ends.
  const bar = $<HTMLCanvasElement>('colorbar');
  const ctx = bar.getContext('2d')!;
  const img = ctx.createImageData(256, 1);
  const table = mapTable(colour.map);
  for (let i = 0; i < 256; i++) img.data.set([table[3 * i], table[3 * i + 1], table[3 * i + 2], 255], 4 * i);
  ctx.putImageData(img, 0, 0);
  bar.title = `${colour.map}: ${clim[0]} to ${clim[1]} (${attribute.name})`;
  requestFrame();
}
cmapSelect.onchange = () => {
  colour.map = cmapSelect.value;
  applyColoring();
};
const rangeChanged = () => {
  const clim = parseClim(`${climLo.value},${climHi.value}`);
  if (clim) colour.clim = clim;
  applyColoring();
};
climLo.onchange = rangeChanged;
climHi.onchange = rangeChanged;
$('clim-auto').onclick = () => {
  colour.clim = null;
  applyColoring();
};

function labelName(i: number): string {
  const l = labels!.table[i];
  const value = labelText(l.value, header!.scalarType);
  return l.name === `label ${value}` ? l.name : `${l.name} (${value})`;
}

function applyHidden(): void {
  if (!renderer || !labels) return;
  renderer.setHiddenClusters(hiddenLabels.size ? hiddenClusters(labels, hiddenLabels) : null);
  stats.hiddenLabels = hiddenLabels.size;
  showLabels();
  requestFrame();
}

/** Rows shown at most; a search narrows a longer list. */
const MAX_LABEL_ROWS = 500;
let pickedLabel: number | null = null;

function showLabels(): void {
  if (!labels) return;
  const l = labels;
  const query = $<HTMLInputElement>('label-search').value.trim().toLowerCase();
  const rows: HTMLElement[] = [];
  let more = 0;
  l.table.forEach((label, i) => {
    const name = labelName(i);
    if (query && !name.toLowerCase().includes(query)) return;
    if (rows.length >= MAX_LABEL_ROWS) {
      more++;
      return;
    }
    const li = document.createElement('li');
    li.dataset.label = String(i);
    if (i === pickedLabel) li.className = 'picked';
    const box = Object.assign(document.createElement('input'), { type: 'checkbox', checked: !hiddenLabels.has(i), title: 'show or hide this label' });
    box.onchange = () => {
      if (box.checked) hiddenLabels.delete(i);
      else hiddenLabels.add(i);
      applyHidden();
    };
    const swatch = document.createElement('span');
    swatch.className = 'swatch';
    swatch.style.background = `rgb(${label.rgba.slice(0, 3).join(',')})`;
    // The name frames the label: its cell box from the index (cells [lo, hi), index space) in world
    // space (index × spacing), as Fit frames the grid (`LabelEntry::world_box`, as `isogrid view` does).
    const text = Object.assign(document.createElement('span'), { textContent: name, title: 'frame this label', className: 'name' });
    text.onclick = () => {
      const e = l.index[i];
      if (e.cellCount) resetCamera([e.lo.map((v, a) => v * header!.spacing[a]), e.hi.map((v, a) => v * header!.spacing[a])]);
    };
    const count = Object.assign(document.createElement('span'), { className: 'count', textContent: l.index[i].cellCount.toLocaleString(), title: 'active cells' });
    li.append(box, swatch, text, count);
    rows.push(li);
  });
  if (more) rows.push(Object.assign(document.createElement('li'), { textContent: `… ${more.toLocaleString()} more: search to narrow the list` }));
  $('label-list').replaceChildren(...rows);
  $('labels-toggle').textContent = `Labels (${l.table.length.toLocaleString()})`;
  $('labels').hidden = false;
}

/** Opens or collapses the label panel to its toggle. At phone width it starts collapsed: open, it
 * would cover most of the picture. */
function setLabelsOpen(open: boolean): void {
  $('labels').classList.toggle('collapsed', !open);
  $('labels-toggle').setAttribute('aria-expanded', String(open));
}
setLabelsOpen(!window.matchMedia('(max-width: 600px)').matches);
$('labels-toggle').onclick = () => setLabelsOpen($('labels').classList.contains('collapsed'));
$('label-search').oninput = showLabels;
$('labels-show').onclick = () => {
  hiddenLabels.clear();
  applyHidden();
};
$('labels-hide').onclick = () => {
  labels?.table.forEach((_, i) => hiddenLabels.add(i));
  applyHidden();
};

/** The canvas pixel under a pointer event. */
function pixelOf(e: PointerEvent | MouseEvent): [number, number] {
  const r = canvas.getBoundingClientRect();
  return [Math.floor(((e.clientX - r.left) * canvas.width) / r.width), Math.floor(((e.clientY - r.top) * canvas.height) / r.height)];
}
const formatValue = (v: number) => (Number.isNaN(v) ? 'no value (NaN)' : String(Number(v.toPrecision(5))));
// The value under the pointer: read from the value target the shading pass wrote (one at a time).
let hover: [number, number] | null = null;
let hoverBusy = false;
async function showHover(): Promise<void> {
  if (hoverBusy || !hover || !renderer || !attribute) return;
  hoverBusy = true;
  const [x, y] = hover;
  hover = null;
  try {
    const hit = await renderer.readPixel(x, y);
    $('readout').textContent = hit ? `value ${formatValue(hit.value)}` : '';
  } finally {
    hoverBusy = false;
    if (hover) showHover();
  }
}
// Clicking a label grid's surface names the label under the cursor.
async function pickLabel(x: number, y: number): Promise<void> {
  if (!renderer || !labels) return;
  const hit = await renderer.readPixel(x, y);
  pickedLabel = hit ? labels.clusterLabels[hit.cluster] : null;
  $('picked').textContent = pickedLabel === null ? 'no surface there' : labelName(pickedLabel);
  showLabels();
  document.querySelector('#label-list li.picked')?.scrollIntoView({ block: 'nearest' });
}

// Controls: drag orbits, shift/right-drag pans, wheel zooms.
let drag: { x: number; y: number; pan: boolean; moved: number } | null = null;
canvas.addEventListener('contextmenu', (e) => e.preventDefault());
canvas.addEventListener('pointerdown', (e) => {
  drag = { x: e.clientX, y: e.clientY, pan: e.shiftKey || e.button === 2, moved: 0 };
  canvas.setPointerCapture(e.pointerId);
});
canvas.addEventListener('pointerup', (e) => {
  // A click (no drag) names the label under the cursor.
  if (drag && drag.moved < 4 && e.button === 0) pickLabel(...pixelOf(e));
  drag = null;
});
canvas.addEventListener('pointermove', (e) => {
  if (!drag) {
    hover = pixelOf(e);
    showHover();
  }
  if (!drag || !camera) return;
  const [dx, dy] = [e.clientX - drag.x, e.clientY - drag.y];
  drag.moved += Math.abs(dx) + Math.abs(dy);
  drag.x = e.clientX;
  drag.y = e.clientY;
  if (drag.pan) {
    const dist = Math.hypot(...camera.eye.map((v, i) => v - camera!.target[i]));
    const s = (2 * dist * Math.tan((camera.fovyDegrees * Math.PI) / 360)) / canvas.clientHeight;
    camera = pan(camera, -dx * s, dy * s);
  } else {
    camera = orbit(camera, -dx * 0.01, -dy * 0.01);
  }
  requestFrame();
});
canvas.addEventListener('wheel', (e) => {
  if (!camera) return;
  e.preventDefault();
  camera = zoom(camera, Math.exp(e.deltaY * 0.001));
  requestFrame();
}, { passive: false });
$('view1').onclick = () => ((view = 1), resetCamera());
$('view2').onclick = () => ((view = 2), resetCamera());
$('fit').onclick = () => resetCamera();
// The clip plane: axis (or none), flip, and position along the axis.
const clipAxis = $<HTMLSelectElement>('clip-axis');
const clipFlip = $<HTMLButtonElement>('clip-flip');
const clipAt = $<HTMLInputElement>('clip-at');
const showClip = () => {
  clipAxis.value = clipControl.axis === null ? '' : String(clipControl.axis);
  clipAt.value = String(Math.round(clipControl.fraction * 1000));
  clipFlip.disabled = clipAt.disabled = clipControl.axis === null;
  clipFlip.setAttribute('aria-pressed', String(clipControl.flip));
};
showClip();
clipAxis.onchange = () => {
  clipControl.axis = clipAxis.value === '' ? null : Number(clipAxis.value);
  showClip();
  requestFrame();
};
clipFlip.onclick = () => {
  clipControl.flip = !clipControl.flip;
  showClip();
  requestFrame();
};
clipAt.oninput = () => {
  clipControl.fraction = Number(clipAt.value) / 1000;
  requestFrame();
};
$('shot').onclick = async () => {
  if (!renderer || !camera) return;
  const px = await renderer.readPixels();
  const c2 = document.createElement('canvas');
  [c2.width, c2.height] = [camera.width, camera.height];
  c2.getContext('2d')!.putImageData(new ImageData(new Uint8ClampedArray(px.buffer as ArrayBuffer), camera.width, camera.height), 0, 0);
  c2.toBlob((b) => {
    const a = document.createElement('a');
    a.href = URL.createObjectURL(b!);
    a.download = `${String(stats.name || 'isogrid').replace(/\.cgc$/, '')}.png`;
    a.click();
  });
};
window.addEventListener('resize', () => {
  if (!fixedSize && camera) {
    const [w, h] = canvasSize();
    camera = { ...camera, width: w, height: h };
    requestFrame();
  }
});

// Loading: ?src=URL, the file input, or a drop anywhere on the page.
const dropHint = $('drop');
const openFile = (f: File | undefined) => {
  if (!f || renderer) {
    if (f) location.reload();
    return;
  }
  if (isPackedName(f.name)) {
    stats.packed = true;
    stats.downloaded = 0;
    load(packedSourceOffThread(f.name, { file: f }, (n) => ((stats.downloaded as number) += n)));
  } else {
    load(blobSource(f));
  }
};
$<HTMLInputElement>('file').onchange = (e) => openFile((e.target as HTMLInputElement).files?.[0]);
document.addEventListener('dragover', (e) => {
  e.preventDefault();
  dropHint.style.display = 'flex';
});
document.addEventListener('dragleave', () => (dropHint.style.display = 'none'));
document.addEventListener('drop', (e) => {
  e.preventDefault();
  dropHint.style.display = 'none';
  openFile(e.dataTransfer?.files[0]);
});
const srcParam = params.get('src');
if (srcParam && isPackedName(srcParam)) {
  // A packed .cgc (.cgcz): one download, rebuilt into the .cgc as it arrives (packed.ts).
  const name = decodeURIComponent(new URL(srcParam, location.href).pathname.split('/').pop() || srcParam);
  stats.packed = true;
  stats.downloaded = 0;
  // Absolute: the rebuild's worker resolves nothing against the page.
  const url = new URL(srcParam, location.href).href;
  load(packedSourceOffThread(name, { url }, (n) => ((stats.downloaded as number) += n)));
} else if (srcParam) {
  // Progress of a whole download (a server without Range support) before the header is parsed.
  let whole = 0;
  load(urlSource(srcParam, (n) => {
    whole += n;
    stats.downloaded = whole;
  }));
}
