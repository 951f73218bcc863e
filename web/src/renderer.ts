// The paper's raster pipeline on WebGPU, pass for pass as crates/isogrid-gpu's
// render/frame_passes.rs, on its shader modules (`isogrid:shaders`, composed from
// crates/isogrid-gpu/shaders/modules.txt) and bind group layouts (passes/scene.rs, upload.rs,
// passes/compute_raster.rs): cluster expansion with the visibility buffer (expand), the cell
// raster, visibility probes and the expansion and raster of newly visible clusters, EWA normal
// splats, the visibility update (visibility) and deferred shading (shade).
// The cell raster and the splats are those of render/frame_passes.rs in either form, chosen per
// frame as `CellRaster::Auto` chooses natively (`widestCellPixels`): compute passes
// (cells_compute.wgsl, ewa_compute.wgsl: one thread per listed cell, atomic depth, integer splat
// sums) while cells project to at most 32 pixels, else screen rectangles through the graphics
// pipeline (cells.wgsl, ewa.wgsl). Cell data is paged: each page is a whole number of clusters
// whose buffers stay within the device's storage binding limit (128 MiB in Firefox), cut as the
// whole file would be cut; clusters join their page as soon as their cells have arrived, so the
// picture fills in while the file streams. Colour
// (colors.ts): the shading pass's `ColorUniforms`; an attribute's codes are paged with the cells
// (after each page's corner records, `recordBytes`, as upload.rs lays them out: the cell raster
// writes the hit cell's code for the shading pass), and a label grid's cluster albedos are one
// colour data binding; hidden labels' clusters get empty metacells in their page's copy, so the
// expansion (expand.wgsl, which skips slots with no cells) never draws them.
// Back faces are culled where the grid's border is outside the solid (BorderCheck) and the eye
// outside the grid box, as natively.

import { SHADERS } from 'isogrid:shaders';
import { Camera, ClipPlane, frameUniforms, FLAG_BACKFACE, FLAG_EWA, FLAG_LABELS, FLAG_OCCLUSION, FRAME_UNIFORM_BYTES, MAX_COMPUTE_CELL_PIXELS, widestCellPixels } from './camera.js';
import { BOUND_SLOT, CLUSTER_SLOTS, SLOT_BYTES } from './cgc.js';
import { COLOR_NONE, COLOR_UNIFORMS_BYTES, colorUniforms } from './colors.js';

const DEPTH_FORMAT: GPUTextureFormat = 'depth32float';
const SURFACE_FORMAT: GPUTextureFormat = 'rgba32float';
const IDS_FORMAT: GPUTextureFormat = 'rg32uint';
const EWA_FORMAT: GPUTextureFormat = 'rgba16float';
export const COLOR_FORMAT: GPUTextureFormat = 'rgba8unorm';
const FINAL_FORMAT: GPUTextureFormat = 'rgba32float';
const VALUE_FORMAT: GPUTextureFormat = 'r32float';
/** Six vertices (one rectangle) per instance; three lists: full, probe, new. */
const EMPTY_ARGS = new Uint32Array([6, 0, 0, 0, 6, 0, 0, 0, 6, 0, 0, 0]);
const LIST_FULL = 0;
const LIST_PROBE = 1;
const LIST_NEW = 2;
/** Bytes of a page's compute dispatch arguments (`PageDispatchArgs`: x, y, z per list). */
const DISPATCH_ARGS_BYTES = 36;
/** Clusters the visibility buffers hold at least (as natively). */
const MIN_VISIBILITY_CLUSTERS = 1 << 20;
/** The passes of a frame, in order; each is bracketed by two timestamp queries where offered. */
export const PASS_NAMES = ['expand', 'cells', 'probe', 'expand new', 'cells new', 'ewa', 'visibility', 'shade'] as const;
type PassName = (typeof PASS_NAMES)[number];
/** The passes that look for clusters coming into view (not in a view's first frame). */
const PROBE_PASSES: PassName[] = ['probe', 'expand new', 'cells new'];

export type CellRaster = 'auto' | 'compute' | 'hardware';

export interface GridDesc {
  precisionBits: number;
  spacing: number[];
  isoCode: number;
  bounds: [number[], number[]];
  slotCount: number;
  /** Corner records (active cells) of the whole grid: pages are sized from what remains. */
  activeCells: number;
  /**
   * A label grid: clusters can be hidden (pages then keep a copy of their metacells), and where
   * two labels' surfaces coincide the face a ray enters wins (FLAG_LABELS).
   */
  labelGrid: boolean;
}

interface Page {
  /** The page's metacell slots as the file holds them (to its capacity), kept where clusters can be hidden. */
  metacells: Uint8Array | null;
  meta: GPUBuffer;
  /** Whether the uploaded copy has emptied clusters. */
  masked: boolean;
  firstSlot: number;
  /** Slots and records in the page so far; it takes clusters up to its capacities. */
  slotCount: number;
  firstCell: number;
  cellCount: number;
  slotCapacity: number;
  cellCapacity: number;
  /** Whether the records carry an attribute's codes, and `PageUniforms.codes_word`: where they start, after the capacity's records (0 without codes). */
  withCodes: boolean;
  codesWord: number;
  uniforms: GPUBuffer;
  records: GPUBuffer;
  /** Instance lists: full, probe, new. */
  lists: GPUBuffer[];
  /** The bytes past the last whole word of the records and of the codes, written again with the next ones. */
  recordTail: Uint8Array;
  codeTail: Uint8Array;
  args: GPUBuffer;
  /** The compute raster's workgroup counts (written by `size_dispatches`) and their bind group. */
  dispatchArgs: GPUBuffer;
  dispatch: GPUBindGroup;
  compute: GPUBindGroup;
  render: GPUBindGroup[];
}

export interface FrameStats {
  /** Which cell raster drew the frame. */
  raster?: 'compute' | 'hardware';
  pages: number;
  /** GPU time of the frame from timestamp queries, where offered (ms). */
  gpuMs: number | null;
}

export class Renderer {
  private pages: Page[] = [];
  /** Slots handed to the pages so far: a frame after new clusters starts from "all visible". */
  private slotsIn = 0;
  private frame = 0;
  private uniforms: GPUBuffer;
  private visibleLast: GPUBuffer;
  private visibleNew: GPUBuffer;
  private volume: GPUTexture;
  private coloring: GPUBuffer;
  private colorData: GPUBuffer;
  private noColorData: GPUBuffer;
  /** Per cluster, 1 when hidden (a label grid's hidden labels); null: all shown. */
  private hidden: Uint8Array | null = null;
  private hiddenVersion = 0;
  private argsTemplate: GPUBuffer;
  private layouts: Record<string, GPUBindGroupLayout> = {};
  private pipelines: Record<string, GPURenderPipeline | GPUComputePipeline> = {};
  private targets: { size: [number, number]; tex: Record<string, GPUTexture>; groups: Record<string, GPUBindGroup>; buffers: GPUBuffer[] } | null = null;
  /** Whether the graphics-pipeline raster is compiled (after `compiled`; used for large cells). */
  private hardwareCompiled = false;
  /** Whether the probe and newly-visible pipelines are compiled (after `compiled`). */
  private probesCompiled = false;
  /** The cell raster of the last frame. */
  lastRaster: 'compute' | 'hardware' = 'compute';
  private sceneCompute: GPUBindGroup;
  private sceneRender: GPUBindGroup;
  private visibilityFor = '';
  /** Whether the grid's border is outside the solid (BorderCheck), so back faces may be culled. */
  private borderOutside = false;
  private query: { set: GPUQuerySet; resolve: GPUBuffer; read: GPUBuffer; busy: boolean } | null = null;
  /** GPU time of the last timed frame, first pass start to last pass end (ms), where offered. */
  lastGpuMs: number | null = null;
  /** GPU time of each pass of the last timed frame (ms), by pass name (PASS_NAMES). */
  lastPassMs: Record<string, number> | null = null;
  /** Wall time the last `render` call took to encode and submit (ms): the frame's JS cost. */
  lastEncodeMs = 0;
  /** Settles once the last frame's timestamps are read (lastGpuMs, lastPassMs); null if it was not timed. */
  lastTimed: Promise<void> | null = null;
  /** Settles when the pipelines of a view's first frame are compiled; draw no frame before. */
  readonly compiled: Promise<void>;
  /** Compiles the other pipelines (once; see the constructor); settles when they are in use. */
  compileRest: () => Promise<void>;
  /** Largest bytes of one page buffer (the storage binding limit, at most 128 MiB). */
  readonly pageBytes: number;

  /**
   * `raster`: which cell raster draws (`isogrid render --cell-raster`): 'auto' as natively, or
   * always 'compute' or 'hardware'. `pageBytes`: a smaller page buffer limit than the device's
   * (at least 256 bytes, as `Renderer::set_page_bytes`), to test paging on small grids.
   */
  constructor(readonly device: GPUDevice, readonly grid: GridDesc, readonly ewa = true, readonly occlusion = true, readonly raster: CellRaster = 'auto', pageBytes?: number) {
    const limit = Math.min(device.limits.maxStorageBufferBindingSize, device.limits.maxBufferSize, 128 << 20);
    this.pageBytes = pageBytes ? Math.min(Math.max(256, pageBytes), limit) : limit;
    const d = device;
    const V = GPUShaderStage.VERTEX, F = GPUShaderStage.FRAGMENT, C = GPUShaderStage.COMPUTE;
    const uniform = (binding: number, visibility: number): GPUBindGroupLayoutEntry => ({ binding, visibility, buffer: { type: 'uniform' } });
    const storage = (binding: number, visibility: number, readOnly: boolean): GPUBindGroupLayoutEntry => ({
      binding,
      visibility,
      buffer: { type: readOnly ? 'read-only-storage' : 'storage' },
    });
    const tex = (binding: number, visibility: number, sampleType: GPUTextureSampleType, viewDimension: GPUTextureViewDimension = '2d'): GPUBindGroupLayoutEntry => ({
      binding,
      visibility,
      texture: { sampleType, viewDimension },
    });
    const layout = (label: string, entries: GPUBindGroupLayoutEntry[]) => (this.layouts[label] = d.createBindGroupLayout({ label, entries }));
    // Group 0 (passes/scene.rs): frame uniforms, visibility bits (last frame, new), original volume.
    layout('scene compute', [uniform(0, C), storage(1, C, false), tex(2, C, 'unfilterable-float', '3d'), storage(3, C, false)]);
    layout('scene render', [uniform(0, V | F), tex(2, V | F, 'unfilterable-float', '3d'), storage(3, F, false)]);
    // Group 1 (upload.rs): a page's uniforms, metacells, records, lists and draw arguments.
    layout('page compute', [uniform(0, C), storage(1, C, true), storage(2, C, true), storage(3, C, false), storage(4, C, false), storage(5, C, false), storage(6, C, false)]);
    layout('page render', [uniform(0, V), storage(1, V, true), storage(2, V, true), storage(3, V, true)]);
    layout('depth input', [tex(0, F, 'depth')]);
    layout('surface input', [tex(0, F, 'unfilterable-float')]);
    layout('ids input', [tex(0, C, 'uint')]);
    // Group 1 of shade.wgsl (passes/shade.rs): G-buffer, EWA sums, ids, colouring, attribute codes.
    const FC = F | C;
    layout('shading inputs', [tex(0, FC, 'unfilterable-float'), tex(1, FC, 'unfilterable-float'), tex(2, FC, 'uint'), uniform(3, FC), storage(4, FC, true)]);
    // Group 2 of `size_dispatches` (upload.rs) and of the compute raster (passes/compute_raster.rs).
    const written = (binding: number, format: GPUTextureFormat): GPUBindGroupLayoutEntry => ({
      binding,
      visibility: C,
      storageTexture: { access: 'write-only', format, viewDimension: '2d' },
    });
    layout('dispatch args', [storage(0, C, false)]);
    layout('compute raster targets', [storage(0, C, false), written(1, SURFACE_FORMAT), written(2, IDS_FORMAT)]);
    layout('compute ewa targets', [storage(0, C, false), tex(1, C, 'unfilterable-float'), written(2, EWA_FORMAT)]);
    // Group 2 of the compute entry of shade.wgsl (passes/shade.rs): the shaded targets as storage.
    layout('compute shading outputs', [written(0, COLOR_FORMAT), written(1, FINAL_FORMAT), written(2, VALUE_FORMAT)]);

    const module = (name: keyof typeof SHADERS) => d.createShaderModule({ label: `${name} (shaders/modules.txt)`, code: SHADERS[name] });
    const pl = (...names: string[]) => d.createPipelineLayout({ bindGroupLayouts: names.map((n) => this.layouts[n]) });
    // The pipelines of a view's first frame (with the compute raster), compiled while the file
    // downloads (SwiftShader takes seconds): see `compiled`; the others by `compileRest`.
    const pending: Promise<unknown>[] = [];
    const set = (name: string, p: Promise<GPURenderPipeline | GPUComputePipeline>) => pending.push(p.then((x) => (this.pipelines[name] = x)));
    const compiledCompute = (name: string, mod: GPUShaderModule, layoutNames: string[], entryPoint: string, constants?: Record<string, number>) =>
      d.createComputePipelineAsync({ label: name, layout: pl(...layoutNames), compute: { module: mod, entryPoint, constants } }).then((x) => (this.pipelines[name] = x));
    const computePipeline = (...args: Parameters<typeof compiledCompute>) => pending.push(compiledCompute(...args));
    const expand = module('expand');
    computePipeline('expand', expand, ['scene compute', 'page compute'], 'expand_visible');
    computePipeline('size dispatches', expand, ['scene compute', 'page compute', 'dispatch args'], 'size_dispatches');
    const rasterModule = module('cells_compute');
    const rasterLayout = ['scene compute', 'page compute', 'compute raster targets'];
    computePipeline('raster clear', rasterModule, rasterLayout, 'clear_targets');
    computePipeline('raster depth', rasterModule, rasterLayout, 'raster_cells', { RASTER_LIST: LIST_FULL, RASTER_RESOLVE: 0 });
    computePipeline('raster resolve', rasterModule, rasterLayout, 'raster_cells', { RASTER_LIST: LIST_FULL, RASTER_RESOLVE: 1 });
    const splats = module('ewa_compute');
    const splatLayout = ['scene compute', 'page compute', 'compute ewa targets'];
    computePipeline('splats', splats, splatLayout, 'splat_cells', { EWA_LIST: LIST_FULL });
    computePipeline('splats resolve', splats, splatLayout, 'resolve_splats');
    const rect = (label: string, layoutNames: string[], mod: GPUShaderModule, vs: string, fs: string, targets: GPUColorTargetState[], depth: boolean): Promise<GPURenderPipeline> =>
      d.createRenderPipelineAsync({
        label,
        layout: pl(...layoutNames),
        vertex: { module: mod, entryPoint: vs },
        fragment: { module: mod, entryPoint: fs, targets },
        primitive: { topology: 'triangle-list', cullMode: 'none' },
        depthStencil: depth ? { format: DEPTH_FORMAT, depthWriteEnabled: true, depthCompare: 'greater' } : undefined,
      });
    computePipeline('visibility', module('visibility'), ['scene compute', 'ids input'], 'update_visibility');
    // Deferred shading as render/frame_passes.rs does it: per pixel in a compute pass after the
    // compute raster, in a full-screen fragment pass after the graphics pipeline raster.
    const shade = module('shade');
    computePipeline('shade compute', shade, ['scene compute', 'shading inputs', 'compute shading outputs'], 'shade_pixels');
    const add: GPUBlendComponent = { srcFactor: 'one', dstFactor: 'one', operation: 'add' };
    // The graphics pipeline raster and splats, for cells of more than 32 pixels, compile after the
    // rest (a failure shows as an uncaptured error; frames keep the compute raster), or with it
    // where they are the only raster.
    const hardware = () =>
      Promise.all([
        rect('cell raster', ['scene render', 'page render'], module('cells'), 'vs_cell', 'fs_cell', [{ format: SURFACE_FORMAT }, { format: IDS_FORMAT }], true),
        rect('ewa normal splats', ['scene render', 'page render', 'surface input'], module('ewa'), 'vs_splat', 'fs_splat', [{ format: EWA_FORMAT, blend: { color: add, alpha: add } }], false),
        rect('visibility probes', ['scene render', 'page render', 'depth input'], module('probe'), 'vs_probe', 'fs_probe', [{ format: IDS_FORMAT, writeMask: 0 }], false),
        rect('deferred shading', ['scene render', 'shading inputs'], shade, 'vs_fullscreen', 'fs_shade', [{ format: COLOR_FORMAT }, { format: FINAL_FORMAT }, { format: VALUE_FORMAT }], false),
      ]).then(([cells, ewa, probe, shadeFragment]) => {
        this.pipelines.cells = cells;
        this.pipelines.ewa = ewa;
        this.pipelines.probe = probe;
        this.pipelines.shade = shadeFragment;
        this.hardwareCompiled = true;
      });
    if (raster === 'hardware') pending.push(hardware());
    this.compiled = Promise.all(pending).then(() => undefined);
    // The probes and the newly-visible passes: a view's first frame starts from "all visible" and
    // has nothing to probe, so they (and the graphics pipeline raster) are compiled by
    // `compileRest`, which the page calls once the file is in and drawn: on a CPU adapter compiling
    // takes seconds of the cores the download needs. Until then every frame is drawn as a first
    // frame (complete, only without the culling's saving) with the compute raster.
    this.compileRest = () => {
      const done = this.compiled
        .then(() =>
          Promise.all([
            compiledCompute('expand new', expand, ['scene compute', 'page compute'], 'expand_new'),
            compiledCompute('raster probe', rasterModule, rasterLayout, 'probe_cells'),
            compiledCompute('raster depth new', rasterModule, rasterLayout, 'raster_cells', { RASTER_LIST: LIST_NEW, RASTER_RESOLVE: 0 }),
            compiledCompute('raster resolve new', rasterModule, rasterLayout, 'raster_cells', { RASTER_LIST: LIST_NEW, RASTER_RESOLVE: 1 }),
            compiledCompute('splats new', splats, splatLayout, 'splat_cells', { EWA_LIST: LIST_NEW }),
          ]),
        )
        .then(() => (this.probesCompiled = true))
        .then(() => (raster === 'auto' ? hardware() : undefined))
        .catch(() => {}); // a failure shows as an uncaptured error; frames stay first frames
      this.compileRest = () => done;
      return done;
    };
    this.uniforms = d.createBuffer({ label: 'frame uniforms', size: FRAME_UNIFORM_BYTES, usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST });
    // ColorUniforms of color.wgsl (gpu_types.rs): COLOR_NONE, the one fixed albedo, until a
    // colouring is set.
    this.coloring = d.createBuffer({ label: 'colouring', size: COLOR_UNIFORMS_BYTES, usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST });
    this.noColorData = d.createBuffer({ label: 'no colour data', size: 16, usage: GPUBufferUsage.STORAGE });
    this.colorData = this.noColorData;
    d.queue.writeBuffer(this.coloring, 0, colorUniforms(COLOR_NONE));
    const clusters = Math.max(Math.ceil(grid.slotCount / CLUSTER_SLOTS), MIN_VISIBILITY_CLUSTERS);
    const visBytes = Math.ceil(clusters / 32) * 4;
    const vis = (label: string) => d.createBuffer({ label, size: visBytes, usage: GPUBufferUsage.STORAGE | GPUBufferUsage.COPY_DST });
    this.visibleLast = vis('visible clusters (last frame)');
    this.visibleNew = vis('newly visible clusters');
    this.volume = d.createTexture({ label: 'unused volume', size: [1, 1, 1], dimension: '3d', format: 'r32float', usage: GPUTextureUsage.TEXTURE_BINDING });
    this.argsTemplate = d.createBuffer({ label: 'empty draw arguments', size: 48, usage: GPUBufferUsage.COPY_SRC | GPUBufferUsage.COPY_DST });
    d.queue.writeBuffer(this.argsTemplate, 0, EMPTY_ARGS);
    const volumeView = this.volume.createView({ dimension: '3d' });
    this.sceneCompute = d.createBindGroup({
      layout: this.layouts['scene compute'],
      entries: [
        { binding: 0, resource: { buffer: this.uniforms } },
        { binding: 1, resource: { buffer: this.visibleLast } },
        { binding: 2, resource: volumeView },
        { binding: 3, resource: { buffer: this.visibleNew } },
      ],
    });
    this.sceneRender = d.createBindGroup({
      layout: this.layouts['scene render'],
      entries: [
        { binding: 0, resource: { buffer: this.uniforms } },
        { binding: 2, resource: volumeView },
        { binding: 3, resource: { buffer: this.visibleNew } },
      ],
    });
    if (d.features.has("timestamp-query")) {
      this.query = {
        set: d.createQuerySet({ type: 'timestamp', count: 2 * PASS_NAMES.length }),
        resolve: d.createBuffer({ size: 16 * PASS_NAMES.length, usage: GPUBufferUsage.QUERY_RESOLVE | GPUBufferUsage.COPY_SRC }),
        read: d.createBuffer({ size: 16 * PASS_NAMES.length, usage: GPUBufferUsage.MAP_READ | GPUBufferUsage.COPY_DST }),
        busy: false,
      };
    }
  }

  get pageCount(): number {
    return this.pages.length;
  }

  /** Bytes of the pages' buffers: their metacells, records, codes, lists and arguments. */
  get pageBufferBytes(): number {
    return this.pages.reduce((sum, p) => sum + [p.uniforms, p.meta, p.records, ...p.lists, p.args, p.dispatchArgs].reduce((t, b) => t + b.size, 0), 0);
  }

  /** Global index of each page's first corner record (and attribute code). */
  get pageFirstRecords(): number[] {
    return this.pages.map((p) => p.firstCell);
  }

  /**
   * Culls back faces (FLAG_BACKFACE) from now on where `outside`: no border sample is inside
   * (BorderCheck), as natively (`border_outside`); only while the eye is outside the grid box.
   */
  setBorderOutside(outside: boolean): void {
    this.borderOutside = outside;
  }

  /** Sets the shading pass's `ColorUniforms` (colors.ts `colorUniforms`). */
  setColoring(uniforms: ArrayBuffer): void {
    this.device.queue.writeBuffer(this.coloring, 0, uniforms);
  }

  /**
   * Uploads a label grid's colour data (each cluster's label albedo), or none. Like the native
   * renderer (upload.rs), albedos larger than one storage binding are refused: the shading pass
   * reads them through one binding by global cluster. Returns why they were refused, or null.
   */
  setColorData(data: ArrayBufferView | null, what: string): string | null {
    if (this.colorData !== this.noColorData) this.colorData.destroy();
    this.colorData = this.noColorData;
    if (data !== null) {
      const size = Math.max(16, Math.ceil(data.byteLength / 4) * 4);
      if (size > this.pageBytes) {
        return `the ${what} takes ${data.byteLength} bytes, more than a storage binding holds (${this.pageBytes} bytes): drawn in one colour`;
      }
      this.colorData = this.device.createBuffer({ label: what, size, usage: GPUBufferUsage.STORAGE | GPUBufferUsage.COPY_DST });
      const padded = new Uint8Array(size);
      padded.set(new Uint8Array(data.buffer, data.byteOffset, data.byteLength));
      this.device.queue.writeBuffer(this.colorData, 0, padded);
    }
    // The shading bind group names the buffer: made again with the targets.
    this.dropTargets();
    return null;
  }

  /**
   * Bytes of a page's records buffer for `cells` cells (`RecordLayout` in upload.rs): the corner
   * records padded to a word, then with an attribute (`codes`) their 16-bit codes, two per word,
   * from word `codesWord` on (0 without codes: `PageUniforms.codes_word`).
   */
  private recordBytes(cells: number, codes: boolean): { bytes: number; codesWord: number } {
    const recordWords = Math.ceil((cells * this.grid.precisionBits) / 4);
    return { bytes: 4 * (recordWords + (codes ? Math.ceil(cells / 2) : 0)), codesWord: codes ? recordWords : 0 };
  }

  /**
   * Hides the clusters marked 1 in `hidden` (one entry per cluster; null shows all): each page
   * whose clusters change is uploaded again with the hidden clusters' metacells emptied.
   */
  setHiddenClusters(hidden: Uint8Array | null): void {
    this.hidden = hidden && hidden.some((h) => h) ? hidden : null;
    this.hiddenVersion++;
    for (const p of this.pages) this.uploadMetacells(p);
  }

  /** Writes page `p`'s metacells again where hiding changed them (a label grid keeps the file's). */
  private uploadMetacells(p: Page): void {
    const first = p.firstSlot / CLUSTER_SLOTS;
    const hides = this.hidden !== null && this.hidden.subarray(first, first + p.slotCount / CLUSTER_SLOTS).some((h) => h);
    if (!hides && !p.masked) return;
    this.writeMetacells(p, 0, p.metacells!.subarray(0, p.slotCount * SLOT_BYTES));
  }

  /** Writes `data`, the page's slots from `fromSlot` on, emptied where their cluster is hidden. */
  private writeMetacells(p: Page, fromSlot: number, data: Uint8Array): void {
    const first = (p.firstSlot + fromSlot) / CLUSTER_SLOTS;
    const count = data.length / (CLUSTER_SLOTS * SLOT_BYTES);
    const hides = this.hidden !== null && this.hidden.subarray(first, first + count).some((h) => h);
    if (hides) {
      data = data.slice();
      for (let c = 0; c < count; c++) {
        if (this.hidden![first + c]) data.fill(0, c * CLUSTER_SLOTS * SLOT_BYTES, (c * CLUSTER_SLOTS + BOUND_SLOT) * SLOT_BYTES);
      }
    }
    if (data.byteLength) this.device.queue.writeBuffer(p.meta, fromSlot * SLOT_BYTES, data.buffer as ArrayBuffer, data.byteOffset, data.byteLength);
    // A whole-page write decides; an appended range can only add emptied clusters.
    p.masked = fromSlot === 0 ? hides : p.masked || hides;
  }

  /**
   * Adds the clusters of slots [firstSlot, firstSlot + slots) (whole clusters, in file order) with
   * their corner records (`cells`, starting at record `firstCell`) and, with an attribute, the
   * records' codes (`codes`, one per record). Clusters go into the last page while they fit its
   * capacity, and a new page is sized for what remains of the grid within the binding limit, so
   * the pages are those of the whole file however it streams in: every pass dispatches once a
   * page, and a dispatch costs a fast GPU more than the cells of a small page.
   */
  addClusters(firstSlot: number, metacells: Uint8Array, firstCell: number, cells: Uint8Array, cellCounts: number[], codes: Uint16Array | null): void {
    // cellCounts[k]: active cells of cluster k of this range.
    const bpc = this.grid.precisionBits;
    let k = 0;
    let cellAt = 0;
    const fits = (q: Page, slots: number, c: number) => q.slotCount + slots <= q.slotCapacity && q.cellCount + c <= q.cellCapacity;
    while (k < cellCounts.length) {
      const slot0 = k * CLUSTER_SLOTS;
      let p = this.pages[this.pages.length - 1];
      if (!p || p.firstSlot + p.slotCount !== firstSlot + slot0 || !fits(p, CLUSTER_SLOTS, cellCounts[k])) {
        this.closeLastPage();
        p = this.openPage(firstSlot + slot0, firstCell + cellAt, cellCounts[k], codes !== null);
      }
      let n = 0;
      let c = 0;
      while (k + n < cellCounts.length && fits(p, (n + 1) * CLUSTER_SLOTS, c + cellCounts[k + n])) c += cellCounts[k + n++];
      this.appendToPage(
        p,
        metacells.subarray(slot0 * SLOT_BYTES, (slot0 + n * CLUSTER_SLOTS) * SLOT_BYTES),
        cells.subarray(cellAt * bpc, (cellAt + c) * bpc),
        codes && codes.subarray(cellAt, cellAt + c),
      );
      this.slotsIn += n * CLUSTER_SLOTS;
      cellAt += c;
      k += n;
    }
  }

  /**
   * A new page from slot `firstSlot` and record `firstCell`, with room for the rest of the grid
   * as far as its records, metacells and instance lists each fit one binding (and at least for
   * `minCells` records and one cluster).
   */
  private openPage(firstSlot: number, firstCell: number, minCells: number, withCodes: boolean): Page {
    const d = this.device;
    const bpc = this.grid.precisionBits;
    const cellsLeft = Math.max(this.grid.activeCells - firstCell, 0);
    const slotsLeft = Math.max(this.grid.slotCount - firstSlot, CLUSTER_SLOTS);
    let cellCapacity = Math.min(cellsLeft, Math.floor(this.pageBytes / 4), Math.floor(this.pageBytes / (bpc + (withCodes ? 2 : 0))));
    while (cellCapacity > 0 && this.recordBytes(cellCapacity, withCodes).bytes > this.pageBytes) cellCapacity--;
    let slotCapacity = Math.min(slotsLeft, Math.floor(this.pageBytes / (SLOT_BYTES * CLUSTER_SLOTS)) * CLUSTER_SLOTS);
    if ((cellCapacity < cellsLeft || slotCapacity < slotsLeft) && cellsLeft > 0) {
      // More than this page remains: whichever of records and slots fills a binding first sizes
      // the page, and the other gets its share at the density of what remains, with a quarter
      // more for denser parts (a page that fills early is closed), so pages do not each reserve
      // a binding's worth of both.
      const cellsPerSlot = cellsLeft / slotsLeft;
      slotCapacity = Math.min(slotCapacity, Math.ceil((1.25 * cellCapacity) / cellsPerSlot / CLUSTER_SLOTS) * CLUSTER_SLOTS);
      cellCapacity = Math.min(cellCapacity, Math.ceil(1.25 * slotCapacity * cellsPerSlot));
    }
    cellCapacity = Math.max(cellCapacity, minCells);
    slotCapacity = Math.max(slotCapacity, CLUSTER_SLOTS);
    const p = this.pages.length;
    const fixed = (label: string, bytes: number, usage: number) => d.createBuffer({ label: `page ${p} ${label}`, size: bytes, usage });
    const uniforms = fixed('uniforms', 16, GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST);
    const args = fixed('draw arguments', EMPTY_ARGS.byteLength, GPUBufferUsage.STORAGE | GPUBufferUsage.INDIRECT | GPUBufferUsage.COPY_SRC | GPUBufferUsage.COPY_DST);
    d.queue.writeBuffer(args, 0, EMPTY_ARGS);
    const dispatchArgs = fixed('dispatch arguments', DISPATCH_ARGS_BYTES, GPUBufferUsage.STORAGE | GPUBufferUsage.INDIRECT);
    const dispatch = d.createBindGroup({ label: `page ${p} dispatch arguments`, layout: this.layouts['dispatch args'], entries: [{ binding: 0, resource: { buffer: dispatchArgs } }] });
    const page: Page = {
      metacells: this.grid.labelGrid ? new Uint8Array(slotCapacity * SLOT_BYTES) : null,
      masked: false,
      firstSlot,
      slotCount: 0,
      firstCell,
      cellCount: 0,
      withCodes,
      uniforms,
      recordTail: new Uint8Array(0),
      codeTail: new Uint8Array(0),
      args,
      dispatchArgs,
      dispatch,
      compute: null!,
      render: [],
      ...this.pageStorage(p, slotCapacity, cellCapacity, withCodes),
    };
    this.bindPage(page, p);
    this.pages.push(page);
    return page;
  }

  /** Page `p`'s storage for `slots` slots and `cells` records: metacells, records with their codes (`recordBytes`), instance lists. */
  private pageStorage(p: number, slots: number, cells: number, withCodes: boolean): Pick<Page, 'meta' | 'records' | 'lists' | 'slotCapacity' | 'cellCapacity' | 'codesWord'> {
    const S = GPUBufferUsage.STORAGE;
    const buffer = (label: string, bytes: number, usage: number) => this.device.createBuffer({ label: `page ${p} ${label}`, size: Math.max(16, Math.ceil(bytes / 4) * 4), usage });
    const { bytes: recordBytes, codesWord } = this.recordBytes(cells, withCodes);
    const meta = buffer('metacells', slots * SLOT_BYTES, S | GPUBufferUsage.COPY_DST | GPUBufferUsage.COPY_SRC);
    const records = buffer('corner records and attribute codes', recordBytes, S | GPUBufferUsage.COPY_DST | GPUBufferUsage.COPY_SRC);
    const lists = [buffer('full list', 4 * cells, S), buffer('probe list', 4 * slots, S), buffer('new list', 4 * cells, S)];
    return { meta, records, lists, slotCapacity: slots, cellCapacity: cells, codesWord };
  }

  /** The bind groups of page `page` (index `p`) over its current buffers. */
  private bindPage(page: Page, p: number): void {
    const d = this.device;
    const buf = (binding: number, b: GPUBuffer): GPUBindGroupEntry => ({ binding, resource: { buffer: b } });
    const { uniforms, meta, records, lists, args } = page;
    page.compute = d.createBindGroup({
      label: `page ${p} (compute)`,
      layout: this.layouts['page compute'],
      entries: [buf(0, uniforms), buf(1, meta), buf(2, records), buf(3, lists[0]), buf(4, lists[1]), buf(5, lists[2]), buf(6, args)],
    });
    page.render = lists.map((l, i) => d.createBindGroup({ label: `page ${p} list ${i}`, layout: this.layouts['page render'], entries: [buf(0, uniforms), buf(1, meta), buf(2, records), buf(3, l)] }));
  }

  /**
   * Shrinks the last page to what it holds once a cluster fits it no more: its capacities were a
   * guess at the density of what remained. The held slots, records and codes are copied on the
   * GPU into buffers of their size (the codes move to their new `codesWord`), so the grid ends
   * up in the buffers one page of each run would have needed.
   */
  private closeLastPage(): void {
    const p = this.pages.length - 1;
    const page = this.pages[p];
    if (!page || (page.slotCount === page.slotCapacity && page.cellCount === page.cellCapacity)) return;
    const withCodes = page.withCodes;
    const old = { meta: page.meta, records: page.records, lists: page.lists, codesWord: page.codesWord };
    Object.assign(page, this.pageStorage(p, page.slotCount, page.cellCount, withCodes));
    const enc = this.device.createCommandEncoder({ label: `page ${p} shrunk to its clusters` });
    const words = (bytes: number) => Math.ceil(bytes / 4) * 4;
    if (page.slotCount) enc.copyBufferToBuffer(old.meta, 0, page.meta, 0, page.slotCount * SLOT_BYTES);
    const recordBytes = words(page.cellCount * this.grid.precisionBits);
    if (recordBytes) enc.copyBufferToBuffer(old.records, 0, page.records, 0, recordBytes);
    if (withCodes && page.cellCount) enc.copyBufferToBuffer(old.records, 4 * old.codesWord, page.records, 4 * page.codesWord, words(2 * page.cellCount));
    this.device.queue.submit([enc.finish()]);
    for (const b of [old.meta, old.records, ...old.lists]) b.destroy();
    if (page.metacells) page.metacells = page.metacells.slice(0, page.slotCount * SLOT_BYTES);
    this.device.queue.writeBuffer(page.uniforms, 0, new Uint32Array([page.firstSlot, page.firstCell, page.slotCount, page.codesWord]));
    this.bindPage(page, p);
  }

  /** Appends clusters' slots, their records and codes to page `p` (within its capacities). */
  private appendToPage(p: Page, metacells: Uint8Array, cells: Uint8Array, codes: Uint16Array | null): void {
    const slot = p.slotCount;
    // A copy, not the view: the view would keep the loader's whole file alive.
    p.metacells?.set(metacells, slot * SLOT_BYTES);
    this.writeMetacells(p, slot, metacells);
    p.recordTail = this.appendWords(p.records, 0, p.cellCount * this.grid.precisionBits, p.recordTail, cells);
    if (codes) p.codeTail = this.appendWords(p.records, 4 * p.codesWord, 2 * p.cellCount, p.codeTail, new Uint8Array(codes.buffer, codes.byteOffset, codes.byteLength));
    p.slotCount += metacells.length / SLOT_BYTES;
    p.cellCount += cells.length / this.grid.precisionBits;
    this.device.queue.writeBuffer(p.uniforms, 0, new Uint32Array([p.firstSlot, p.firstCell, p.slotCount, p.codesWord]));
  }

  /**
   * Writes `data` after the `filled` bytes from `base` in `buffer`, whose last `tail` bytes (those
   * past the last whole word) go again in front of it, as writes are whole words; returns the new tail.
   */
  private appendWords(buffer: GPUBuffer, base: number, filled: number, tail: Uint8Array, data: Uint8Array): Uint8Array {
    if (!data.length) return tail;
    const bytes = tail.length + data.length;
    const words = new Uint8Array(Math.ceil(bytes / 4) * 4);
    words.set(tail);
    words.set(data, tail.length);
    this.device.queue.writeBuffer(buffer, base + filled - tail.length, words);
    return words.slice(bytes - (bytes % 4), bytes);
  }

  /** Frees the size-dependent targets (made again by the next frame). */
  private dropTargets(): void {
    if (this.targets) for (const t of [...Object.values(this.targets.tex), ...this.targets.buffers]) t.destroy();
    this.targets = null;
  }

  private ensureTargets(width: number, height: number): void {
    if (this.targets && this.targets.size[0] === width && this.targets.size[1] === height) return;
    this.dropTargets();
    const d = this.device;
    const U = GPUTextureUsage;
    const t = (label: string, format: GPUTextureFormat, usage: number) => d.createTexture({ label, size: [width, height], format, usage });
    const rt = U.RENDER_ATTACHMENT | U.TEXTURE_BINDING;
    const tex = {
      depth: t('raster depth (reversed-Z)', DEPTH_FORMAT, rt),
      surface: t('raster normal + distance', SURFACE_FORMAT, rt | U.STORAGE_BINDING),
      ids: t('cluster ids', IDS_FORMAT, rt | U.STORAGE_BINDING | U.COPY_SRC),
      ewa: t('ewa normal accumulation', EWA_FORMAT, rt | U.STORAGE_BINDING),
      color: t('shaded colour', COLOR_FORMAT, U.RENDER_ATTACHMENT | U.STORAGE_BINDING | U.COPY_SRC),
      final: t('final normal + distance', FINAL_FORMAT, U.RENDER_ATTACHMENT | U.STORAGE_BINDING),
      value: t('shaded attribute value', VALUE_FORMAT, U.RENDER_ATTACHMENT | U.STORAGE_BINDING | U.COPY_SRC),
    };
    // The compute raster's per-pixel depth words and the splats' fixed-point sums (4 words a pixel).
    const depthWords = d.createBuffer({ label: 'compute raster depth words', size: 4 * width * height, usage: GPUBufferUsage.STORAGE });
    const ewaSum = d.createBuffer({ label: 'compute ewa sums', size: 16 * width * height, usage: GPUBufferUsage.STORAGE | GPUBufferUsage.COPY_DST });
    const g = (layout: string, resources: GPUBindingResource[]) =>
      d.createBindGroup({ layout: this.layouts[layout], entries: resources.map((resource, i) => ({ binding: i, resource })) });
    this.targets = {
      size: [width, height],
      tex,
      buffers: [depthWords, ewaSum],
      groups: {
        depth: g('depth input', [tex.depth.createView()]),
        surface: g('surface input', [tex.surface.createView()]),
        ids: g('ids input', [tex.ids.createView()]),
        raster: g('compute raster targets', [{ buffer: depthWords }, tex.surface.createView(), tex.ids.createView()]),
        splats: g('compute ewa targets', [{ buffer: ewaSum }, tex.surface.createView(), tex.ewa.createView()]),
        shade: g('shading inputs', [tex.surface.createView(), tex.ewa.createView(), tex.ids.createView(), { buffer: this.coloring }, { buffer: this.colorData }]),
        shaded: g('compute shading outputs', [tex.color.createView(), tex.final.createView(), tex.value.createView()]),
      },
    };
  }

  /** Resets the visibility bits to "every cluster visible", so the next frame is complete. */
  resetVisibility(): void {
    this.visibilityFor = '';
  }

  /**
   * Encodes one frame of `camera` into the colour target, copied into `output` when given; the
   * surface beyond `clip` is cut away (the shaders clip each cell's ray segment).
   */
  render(camera: Camera, output: GPUTexture | null, clip: ClipPlane | null = null): GPUTexture {
    const encodeStart = performance.now();
    const d = this.device;
    this.ensureTargets(camera.width, camera.height);
    const T = this.targets!;
    // Visibility persists while the camera, clip plane, hidden labels, culling and data stay;
    // anything else starts from "all visible", so the frame after a change is complete.
    const [lo, hi] = this.grid.bounds;
    const eyeOutside = camera.eye.some((e, a) => e < lo[a] || e > hi[a]);
    const backface = this.borderOutside && eyeOutside;
    const key = JSON.stringify([camera, clip, this.slotsIn, this.hiddenVersion, backface]);
    // A first frame of a view has every cluster in the full list: no probes, no newly visible.
    const fresh = key !== this.visibilityFor || !this.probesCompiled;
    const probing = this.occlusion && !fresh;
    if (fresh) {
      d.queue.writeBuffer(this.visibleLast, 0, new Uint8Array(this.visibleLast.size).fill(0xff));
      d.queue.writeBuffer(this.visibleNew, 0, new Uint8Array(this.visibleNew.size));
      this.visibilityFor = key;
    }
    let flags = 0;
    if (this.occlusion) flags |= FLAG_OCCLUSION;
    if (backface) flags |= FLAG_BACKFACE;
    if (this.ewa) flags |= FLAG_EWA;
    // Touching labels' surfaces coincide: the face a ray enters must win the depth test over the
    // one it leaves, as natively (uniforms.rs), or an eye inside the grid or a clip plane through
    // it sees their boundary speckle.
    if (this.grid.labelGrid) flags |= FLAG_LABELS;
    d.queue.writeBuffer(this.uniforms, 0, frameUniforms(camera, this.grid, flags, this.frame++, clip));
    const enc = d.createCommandEncoder({ label: 'frame' });
    const timed = this.query && !this.query.busy ? this.query : null;
    // Each pass's timestamps: begin at 2i, end at 2i + 1 (i its index in PASS_NAMES).
    const at = (name: PassName) => {
      const i = PASS_NAMES.indexOf(name);
      return timed ? { querySet: timed.set, beginningOfPassWriteIndex: 2 * i, endOfPassWriteIndex: 2 * i + 1 } : undefined;
    };
    // `CellRaster::Auto`: the compute raster unless a cell can cover more than 32 pixels across
    // (and the graphics pipeline raster is compiled).
    const compute =
      this.raster === 'compute' ||
      (this.raster === 'auto' && (!this.hardwareCompiled || widestCellPixels(camera, this.grid.spacing, this.grid.bounds) <= MAX_COMPUTE_CELL_PIXELS));
    this.lastRaster = compute ? 'compute' : 'hardware';
    for (const p of this.pages) enc.copyBufferToBuffer(this.argsTemplate, 0, p.args, 0, 48);
    this.expand(enc, 'expand', compute, at('expand'));
    const pixels = [Math.ceil(camera.width / 8), Math.ceil(camera.height / 8)] as const;
    if (compute) {
      // render/frame_passes.rs with the compute raster: clear and the atomic depth of the visible
      // clusters' cells; probes against that depth; the newly visible clusters' depth; then the
      // cells whose depth won write the G-buffer (a first frame has no probes: depth and resolve).
      const steps = (pass: GPUComputePassEncoder, names: string[], list: number) => {
        for (const name of names) {
          pass.setPipeline(this.pipelines[name] as GPUComputePipeline);
          for (const p of this.pages) {
            pass.setBindGroup(1, p.compute);
            pass.dispatchWorkgroupsIndirect(p.dispatchArgs, 12 * list);
          }
        }
      };
      const raster = (name: PassName) => {
        const r = enc.beginComputePass({ timestampWrites: at(name) });
        r.setBindGroup(0, this.sceneCompute);
        r.setBindGroup(2, T.groups.raster);
        return r;
      };
      let r = raster('cells');
      if (this.pages.length) {
        r.setBindGroup(1, this.pages[0].compute); // in the layout, unused by the clear
        r.setPipeline(this.pipelines['raster clear'] as GPUComputePipeline);
        r.dispatchWorkgroups(...pixels);
      }
      steps(r, probing ? ['raster depth'] : ['raster depth', 'raster resolve'], LIST_FULL);
      r.end();
      if (probing) {
        r = raster('probe');
        steps(r, ['raster probe'], LIST_PROBE);
        r.end();
        this.expand(enc, 'expand new', true, at('expand new'));
        r = raster('cells new');
        steps(r, ['raster depth new'], LIST_NEW);
        steps(r, ['raster resolve'], LIST_FULL);
        steps(r, ['raster resolve new'], LIST_NEW);
        r.end();
      }
      if (this.ewa && this.pages.length) {
        enc.clearBuffer(T.buffers[1]);
        const e = enc.beginComputePass({ timestampWrites: at('ewa') });
        e.setBindGroup(0, this.sceneCompute);
        e.setBindGroup(2, T.groups.splats);
        steps(e, ['splats'], LIST_FULL);
        if (probing) steps(e, ['splats new'], LIST_NEW);
        e.setPipeline(this.pipelines['splats resolve'] as GPUComputePipeline);
        e.dispatchWorkgroups(...pixels);
        e.end();
      } else {
        enc.beginRenderPass({ colorAttachments: [{ view: T.tex.ewa.createView(), loadOp: 'clear', clearValue: [0, 0, 0, 0], storeOp: 'store' }] }).end();
      }
    } else {
      const gbuffer = (clear: boolean, name: PassName): GPURenderPassDescriptor => ({
        colorAttachments: [
          { view: T.tex.surface.createView(), loadOp: clear ? 'clear' : 'load', clearValue: [0, 0, 0, 0], storeOp: 'store' },
          { view: T.tex.ids.createView(), loadOp: clear ? 'clear' : 'load', clearValue: [0xffffffff, 0xffffffff, 0, 0], storeOp: 'store' },
        ],
        depthStencilAttachment: { view: T.tex.depth.createView(), depthLoadOp: clear ? 'clear' : 'load', depthClearValue: 0, depthStoreOp: 'store' },
        timestampWrites: at(name),
      });
      let pass = enc.beginRenderPass(gbuffer(true, 'cells'));
      this.draw(pass, 'cells', LIST_FULL, []);
      pass.end();
      if (probing) {
        pass = enc.beginRenderPass({ colorAttachments: [{ view: T.tex.ids.createView(), loadOp: 'load', storeOp: 'store' }], timestampWrites: at('probe') });
        this.draw(pass, 'probe', LIST_PROBE, [[2, T.groups.depth]]);
        pass.end();
        this.expand(enc, 'expand new', false, at('expand new'));
        pass = enc.beginRenderPass(gbuffer(false, 'cells new'));
        this.draw(pass, 'cells', LIST_NEW, []);
        pass.end();
      }
      pass = enc.beginRenderPass({
        colorAttachments: [{ view: T.tex.ewa.createView(), loadOp: 'clear', clearValue: [0, 0, 0, 0], storeOp: 'store' }],
        timestampWrites: this.ewa ? at('ewa') : undefined,
      });
      if (this.ewa) {
        this.draw(pass, 'ewa', LIST_FULL, [[2, T.groups.surface]]);
        if (probing) this.draw(pass, 'ewa', LIST_NEW, [[2, T.groups.surface]]);
      }
      pass.end();
    }
    if (this.occlusion) {
      enc.clearBuffer(this.visibleLast);
      enc.clearBuffer(this.visibleNew);
      const v = enc.beginComputePass({ timestampWrites: at('visibility') });
      v.setPipeline(this.pipelines.visibility as GPUComputePipeline);
      v.setBindGroup(0, this.sceneCompute);
      v.setBindGroup(1, T.groups.ids);
      v.dispatchWorkgroups(Math.ceil(camera.width / 8), Math.ceil(camera.height / 8));
      v.end();
    }
    if (compute) {
      // Every pixel is written, so the targets need no clear.
      const pass = enc.beginComputePass({ timestampWrites: at('shade') });
      pass.setPipeline(this.pipelines['shade compute'] as GPUComputePipeline);
      pass.setBindGroup(0, this.sceneCompute);
      pass.setBindGroup(1, T.groups.shade);
      pass.setBindGroup(2, T.groups.shaded);
      pass.dispatchWorkgroups(...pixels);
      pass.end();
    } else {
      const pass = enc.beginRenderPass({
        colorAttachments: [
          { view: T.tex.color.createView(), loadOp: 'clear', clearValue: [0, 0, 0, 1], storeOp: 'store' },
          { view: T.tex.final.createView(), loadOp: 'clear', clearValue: [0, 0, 0, 0], storeOp: 'store' },
          { view: T.tex.value.createView(), loadOp: 'clear', clearValue: [0, 0, 0, 0], storeOp: 'store' },
        ],
        timestampWrites: at('shade'),
      });
      pass.setPipeline(this.pipelines.shade as GPURenderPipeline);
      pass.setBindGroup(0, this.sceneRender);
      pass.setBindGroup(1, T.groups.shade);
      pass.draw(3);
      pass.end();
    }
    if (output) enc.copyTextureToTexture({ texture: T.tex.color }, { texture: output }, [camera.width, camera.height]);
    if (timed) {
      enc.resolveQuerySet(timed.set, 0, 2 * PASS_NAMES.length, timed.resolve, 0);
      enc.copyBufferToBuffer(timed.resolve, 0, timed.read, 0, timed.read.size);
    }
    d.queue.submit([enc.finish()]);
    this.lastEncodeMs = performance.now() - encodeStart;
    this.lastTimed = null;
    if (timed) {
      timed.busy = true;
      const ran = PASS_NAMES.filter((n) =>
        PROBE_PASSES.includes(n) ? probing : n === 'visibility' ? this.occlusion : n === 'ewa' ? this.ewa && (this.pages.length > 0 || !compute) : true,
      );
      this.lastTimed = timed.read.mapAsync(GPUMapMode.READ).then(
        () => {
          const t = new BigInt64Array(timed.read.getMappedRange().slice(0));
          timed.read.unmap();
          timed.busy = false;
          // Passes that ran (the others' queries are never written); the frame spans the first to the last.
          const passes: Record<string, number> = {};
          let first: bigint | null = null;
          let last: bigint | null = null;
          for (const name of ran) {
            const i = PASS_NAMES.indexOf(name);
            passes[name] = Number(t[2 * i + 1] - t[2 * i]) / 1e6;
            if (first === null || t[2 * i] < first) first = t[2 * i];
            if (last === null || t[2 * i + 1] > last) last = t[2 * i + 1];
          }
          const ns = first !== null && last !== null ? Number(last - first) : 0;
          this.lastGpuMs = ns > 0 ? ns / 1e6 : null;
          this.lastPassMs = ns > 0 ? passes : null;
        },
        () => {
          timed.busy = false;
        },
      );
    }
    return T.tex.color;
  }

  /**
   * The expansion of the visible clusters ('expand') or of the newly visible ones ('expand new')
   * over every page; with the compute raster, the workgroup counts of its lists follow.
   */
  private expand(enc: GPUCommandEncoder, which: 'expand' | 'expand new', sizeDispatches: boolean, timestampWrites?: GPUComputePassTimestampWrites): void {
    const c = enc.beginComputePass({ timestampWrites });
    c.setBindGroup(0, this.sceneCompute);
    c.setPipeline(this.pipelines[which] as GPUComputePipeline);
    for (const p of this.pages) {
      c.setBindGroup(1, p.compute);
      const groups = Math.max(Math.ceil(p.slotCount / 64), 1);
      const x = Math.min(groups, 65535);
      c.dispatchWorkgroups(x, Math.ceil(groups / x));
    }
    if (sizeDispatches) {
      c.setPipeline(this.pipelines['size dispatches'] as GPUComputePipeline);
      for (const p of this.pages) {
        c.setBindGroup(1, p.compute);
        c.setBindGroup(2, p.dispatch);
        c.dispatchWorkgroups(1);
      }
    }
    c.end();
  }

  private draw(pass: GPURenderPassEncoder, pipeline: string, list: number, extra: [number, GPUBindGroup][]): void {
    pass.setPipeline(this.pipelines[pipeline] as GPURenderPipeline);
    pass.setBindGroup(0, this.sceneRender);
    for (const [i, g] of extra) pass.setBindGroup(i, g);
    for (const p of this.pages) {
      pass.setBindGroup(1, p.render[list]);
      pass.drawIndirect(p.args, 16 * list);
    }
  }

  /** Instances (cells) the last frame listed, summed over the pages: full, probe and new lists. */
  async listedCells(): Promise<{ full: number; probe: number; new: number }> {
    const n = Math.max(this.pages.length, 1);
    const buf = this.device.createBuffer({ size: 48 * n, usage: GPUBufferUsage.COPY_DST | GPUBufferUsage.MAP_READ });
    const enc = this.device.createCommandEncoder();
    this.pages.forEach((p, i) => enc.copyBufferToBuffer(p.args, 0, buf, 48 * i, 48));
    this.device.queue.submit([enc.finish()]);
    await buf.mapAsync(GPUMapMode.READ);
    const a = new Uint32Array(buf.getMappedRange().slice(0));
    buf.unmap();
    buf.destroy();
    const sum = (list: number) => this.pages.reduce((t, _, i) => t + a[12 * i + 4 * list + 1], 0);
    return { full: sum(LIST_FULL), probe: sum(LIST_PROBE), new: sum(LIST_NEW) };
  }

  /**
   * What the last frame shows at pixel (x, y): the hit's cluster and record (null on a miss) from
   * the ID target and the attribute value the shading pass wrote (NaN where none).
   */
  async readPixel(x: number, y: number): Promise<{ cluster: number; record: number; value: number } | null> {
    const T = this.targets;
    if (!T || x < 0 || y < 0 || x >= T.size[0] || y >= T.size[1]) return null;
    const buf = this.device.createBuffer({ size: 512, usage: GPUBufferUsage.COPY_DST | GPUBufferUsage.MAP_READ });
    const enc = this.device.createCommandEncoder();
    enc.copyTextureToBuffer({ texture: T.tex.ids, origin: [x, y] }, { buffer: buf, bytesPerRow: 256 }, [1, 1]);
    enc.copyTextureToBuffer({ texture: T.tex.value, origin: [x, y] }, { buffer: buf, offset: 256, bytesPerRow: 256 }, [1, 1]);
    this.device.queue.submit([enc.finish()]);
    await buf.mapAsync(GPUMapMode.READ);
    const ids = new Uint32Array(buf.getMappedRange(0, 8).slice(0));
    const value = new Float32Array(buf.getMappedRange(256, 4).slice(0))[0];
    buf.unmap();
    buf.destroy();
    return ids[0] === 0xffffffff ? null : { cluster: ids[0], record: ids[1], value };
  }

  /** The value target (f32 rows top to bottom; NaN on a miss or where uncoloured), for tests. */
  async readValues(): Promise<Float32Array> {
    return new Float32Array((await this.readTarget('value')).buffer);
  }

  /** The colour target's pixels, RGBA8 rows top to bottom (for tests and screenshots). */
  async readPixels(): Promise<Uint8Array> {
    return this.readTarget('color');
  }

  /** The hit cluster under each pixel (0xffffffff on a miss), rows top to bottom, for tests. */
  async readClusters(): Promise<Uint32Array> {
    const ids = new Uint32Array((await this.readTarget('ids', 8)).buffer);
    return ids.filter((_, i) => i % 2 === 0);
  }

  /** The bytes of a target of `bytes` per pixel, rows top to bottom. */
  private async readTarget(which: 'color' | 'value' | 'ids', bytes = 4): Promise<Uint8Array> {
    const T = this.targets!;
    const [w, h] = T.size;
    const row = Math.ceil((w * bytes) / 256) * 256;
    const buf = this.device.createBuffer({ size: row * h, usage: GPUBufferUsage.COPY_DST | GPUBufferUsage.MAP_READ });
    const enc = this.device.createCommandEncoder();
    enc.copyTextureToBuffer({ texture: T.tex[which] }, { buffer: buf, bytesPerRow: row }, [w, h]);
    this.device.queue.submit([enc.finish()]);
    await buf.mapAsync(GPUMapMode.READ);
    const src = new Uint8Array(buf.getMappedRange());
    const out = new Uint8Array(w * h * bytes);
    for (let y = 0; y < h; y++) out.set(src.subarray(y * row, y * row + w * bytes), y * w * bytes);
    buf.unmap();
    buf.destroy();
    return out;
  }
}
