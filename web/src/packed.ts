// Rebuilds a .cgc file from its packed transfer form (.cgcz: each corner sample once, predicted
// from its neighbours, positions as Morton steps, range-coded; the layout is the module doc of
// crates/isogrid/src/cgc/pack.rs, which writes it) while it downloads, and hands the rebuilt bytes
// to streamCgc as a ByteSource: a read resolves once every byte it asks for is rebuilt. So the
// packed file is validated as any .cgc is (header, table, every section's CRC, the structure), and
// its clusters are drawn as they arrive, chunk by chunk. The browser's DecompressionStream inflates
// the preamble; rangecoder.ts decodes the blocks.

import { Crc32 } from './crc32.js';
import { ATTRIBUTE_HEAD_SIZE, BLOCK_BYTES, BLOCK_CELLS, BOUND_SLOT, CgcError, CgcHeader, CLUSTER_SLOTS, SECTION_WORLD_FRAME, SLOT_BYTES, Section, blockDims, parseHeader } from './cgc.js';
import type { ByteSource } from './loader.js';
import { BlockModels, RangeDecoder, bitLength, residualContext, unfoldResidual } from './rangecoder.js';

export const PACKED_MAGIC = [0x89, 0x43, 0x47, 0x5a, 0x0d, 0x0a, 0x1a, 0x0a];
export const PACKED_HEAD_SIZE = 56;
const PACKED_VERSION = 2;
const HEADER_SIZE = 320;
const TABLE_ENTRY_SIZE = 32;
/** Samples along a block's edge (its high face included) and in a block. */
const SIDE = BLOCK_CELLS + 1;
const BOX = SIDE * SIDE * SIDE;
const CLUSTER_METACELLS = CLUSTER_SLOTS - 1;
/** Box index offset of corner (or cell bit) q: +x, +y, +z in bits 0, 1, 2. */
const CORNER_OFFSETS = [0, 1, 2, 3, 4, 5, 6, 7].map((q) => (q >> 2) * SIDE * SIDE + ((q >> 1) & 1) * SIDE + (q & 1));

/** Whether a file's name says it is a packed .cgc. */
export function isPackedName(name: string): boolean {
  return /\.cgcz$/i.test(name.split(/[?#]/)[0]);
}

/** The inflated preamble, read in order. */
class Preamble {
  private at = 0;
  constructor(private readonly b: Uint8Array) {}
  bytes(n: number): Uint8Array {
    if (this.at + n > this.b.length) throw new CgcError('the packed preamble ends early (damaged)');
    const out = this.b.subarray(this.at, this.at + n);
    this.at += n;
    return out;
  }
  varint(): number {
    let v = 0;
    for (let shift = 0; shift < 49; shift += 7) {
      const b = this.bytes(1)[0];
      v += (b & 0x7f) * 2 ** shift;
      if (b < 0x80) return v;
    }
    throw new CgcError('a varint of the packed file is too long (damaged)');
  }
  /** Checks that every inflated byte was used. */
  end(): void {
    if (this.at !== this.b.length) throw new CgcError('the packed preamble has bytes left over (damaged)');
  }
}

/** The packed file's bytes as they download, taken in order. */
class Download {
  private buf = new Uint8Array(0);
  private at = 0;
  private received = 0;
  /** Bytes taken so far, from the file's start. */
  taken = 0;
  /** The file's length once its head is in. */
  private total = Infinity;
  constructor(private readonly reader: ReadableStreamDefaultReader<Uint8Array>, private readonly onBytes: (n: number) => void) {}

  /** Sets the file's length, which the bytes so far must not pass. */
  setTotal(total: number): void {
    this.total = total;
    if (this.received > total) throw new CgcError(`the packed file runs past the ${total} bytes its head gives (damaged)`);
  }
  /** Pulls until `n` unread bytes are buffered; false at the download's end. */
  private async fill(n: number): Promise<boolean> {
    while (this.buf.length - this.at < n) {
      const { done, value } = await this.reader.read();
      if (done) return false;
      this.onBytes(value.length);
      this.received += value.length;
      if (this.received > this.total) throw new CgcError(`the packed file runs past the ${this.total} bytes its head gives (damaged)`);
      const rest = this.buf.subarray(this.at);
      const next = new Uint8Array(rest.length + value.length);
      next.set(rest);
      next.set(value, rest.length);
      this.buf = next;
      this.at = 0;
    }
    return true;
  }
  /** The next `n` bytes; `inside` names the part of the head they are in, for a truncation before the file's length is known. */
  async take(n: number, inside = 'head'): Promise<Uint8Array> {
    if (!(await this.fill(n))) {
      throw new CgcError(
        this.total === Infinity
          ? `the packed file ends after ${this.received} bytes, inside its ${inside} (truncated?)`
          : `the packed file ends after ${this.received} of its ${this.total} bytes (truncated?)`,
      );
    }
    const out = this.buf.subarray(this.at, this.at + n);
    this.at += n;
    this.taken += n;
    return out;
  }
  async varint(): Promise<number> {
    let v = 0;
    for (let shift = 0; shift < 49; shift += 7) {
      const b = (await this.take(1))[0];
      v += (b & 0x7f) * 2 ** shift;
      if (b < 0x80) return v;
    }
    throw new CgcError('a varint of the packed file is too long (damaged)');
  }
  /** Checks that the download ends here. */
  async end(): Promise<void> {
    if (await this.fill(1)) throw new CgcError(`the packed file runs past the ${this.total} bytes its head gives (damaged)`);
  }
  cancel(): void {
    this.reader.cancel().catch(() => {});
  }
}

/** `deflated` inflated by the browser, refused past `expected` bytes or short of them. */
async function inflate(deflated: Uint8Array, expected: number): Promise<Uint8Array> {
  const out = new Uint8Array(expected);
  let filled = 0;
  try {
    const stream = new Blob([deflated as Uint8Array<ArrayBuffer>]).stream().pipeThrough(new DecompressionStream('deflate-raw'));
    const reader = stream.getReader();
    for (;;) {
      const { done, value } = await reader.read();
      if (done) break;
      if (filled + value.length > expected) {
        reader.cancel().catch(() => {});
        throw new CgcError(`the packed preamble inflates past the ${expected} bytes its head gives (damaged)`);
      }
      out.set(value, filled);
      filled += value.length;
    }
  } catch (e) {
    if (e instanceof CgcError) throw e;
    throw new CgcError('the packed preamble is damaged (not valid deflate data)');
  }
  if (filled !== expected) throw new CgcError(`the packed preamble inflates to ${filled} of the ${expected} bytes its head gives (damaged)`);
  return out;
}

/**
 * The predicted code of the new sample at block-local (x, y, z) under predictor `mode` from the
 * samples of its box known so far (-1: unknown): `predict` of crates/isogrid/src/cgc/pack.rs,
 * which the test of this module holds to by rebuilding files that it packed.
 */
function predict(known: Float64Array, x: number, y: number, z: number, max: number, last: number, mode: number): number {
  const at = z * SIDE * SIDE + y * SIDE + x;
  const a = x > 0 ? known[at - 1] : -1;
  const b = y > 0 ? known[at - SIDE] : -1;
  const c = z > 0 ? known[at - SIDE * SIDE] : -1;
  let sum = 0;
  let n = 0;
  if (mode === 1) {
    // Along each axis, the line through the two samples before this one; their median.
    const aa = x > 1 ? known[at - 2] : -1;
    const bb = y > 1 ? known[at - 2 * SIDE] : -1;
    const cc = z > 1 ? known[at - 2 * SIDE * SIDE] : -1;
    const la = a >= 0 && aa >= 0 ? Math.min(Math.max(2 * a - aa, 0), max) : -1;
    const lb = b >= 0 && bb >= 0 ? Math.min(Math.max(2 * b - bb, 0), max) : -1;
    const lc = c >= 0 && cc >= 0 ? Math.min(Math.max(2 * c - cc, 0), max) : -1;
    const k = (la >= 0 ? 1 : 0) + (lb >= 0 ? 1 : 0) + (lc >= 0 ? 1 : 0);
    if (k === 3) return Math.max(Math.min(la, lb), Math.min(Math.max(la, lb), lc));
    // Of two, their mean rounded up: the third is -1, so the two sum to la + lb + lc + 1.
    if (k === 2) return Math.floor((la + lb + lc + 2) / 2);
    if (k === 1) return Math.max(la, lb, lc);
  }
  if (a >= 0 && b >= 0) {
    const ab = known[at - 1 - SIDE];
    if (ab >= 0) {
      const p = a + b - ab;
      sum += p < 0 ? 0 : p > max ? max : p;
      n++;
    }
  }
  if (a >= 0 && c >= 0) {
    const ac = known[at - 1 - SIDE * SIDE];
    if (ac >= 0) {
      const p = a + c - ac;
      sum += p < 0 ? 0 : p > max ? max : p;
      n++;
    }
  }
  if (b >= 0 && c >= 0) {
    const bc = known[at - SIDE - SIDE * SIDE];
    if (bc >= 0) {
      const p = b + c - bc;
      sum += p < 0 ? 0 : p > max ? max : p;
      n++;
    }
  }
  if (n === 0) {
    if (a >= 0) (sum += a), n++;
    if (b >= 0) (sum += b), n++;
    if (c >= 0) (sum += c), n++;
  }
  if (n === 0) return last;
  return Math.floor((2 * sum + n) / (2 * n));
}

/** Milliseconds of rebuilding between chances for the page to draw. */
const YIELD_MS = 8;

/** Resolves after the tasks queued so far (frames, input, network) have run. */
function yieldToPage(): Promise<void> {
  return new Promise((resolve) => {
    const channel = new MessageChannel();
    channel.port1.onmessage = () => {
      channel.port1.close();
      resolve();
    };
    channel.port2.postMessage(null);
  });
}

/** Morton code of a metacell inside a block → its coordinates (0..8 each). */
function mortonDecode(code: number): [number, number, number] {
  const compact = (v: number) => (v & 1) | ((v >> 2) & 2) | ((v >> 4) & 4);
  return [compact(code), compact(code >> 1), compact(code >> 2)];
}

/** Where a packed file comes from: an absolute URL to fetch, or a local file (a drop, the file input). */
export type PackedOrigin = { url: string } | { file: File };

/** The `open` of [packedSource] for `origin`; an HTTP failure names the file. */
export function openPacked(origin: PackedOrigin, name: string): () => Promise<ReadableStream<Uint8Array>> {
  if ('file' in origin) return async () => origin.file.stream();
  return async () => {
    const res = await fetch(origin.url);
    if (!res.ok || !res.body) throw new Error(`${name}: HTTP ${res.status} ${res.statusText}`);
    return res.body;
  };
}

/**
 * A ByteSource of the .cgc that the packed file `open` streams (a .cgcz download or a dropped
 * file) rebuilds. `onBytes` counts the packed bytes as they arrive; `total` is the .cgc's length
 * once the head is in.
 */
export function packedSource(name: string, open: () => Promise<ReadableStream<Uint8Array>>, onBytes: (n: number) => void): ByteSource {
  let file: Uint8Array | null = null;
  let header: CgcHeader | null = null;
  let failure: unknown = null;
  /** Bytes rebuilt from each section's start. */
  const filled = new Map<Section, number>();
  const waiting: { start: number; end: number; resolve: (b: Uint8Array) => void; reject: (e: unknown) => void }[] = [];
  // The file's last byte waits until the download is known to end where its head says: a
  // packed file with bytes past its end is refused, not rebuilt.
  let complete = false;
  const ready = (start: number, end: number): boolean =>
    header !== null &&
    (complete || end < file!.length) &&
    header.sections.every((s) => end <= s.offset || start >= s.offset + s.length || filled.get(s)! >= Math.min(end, s.offset + s.length) - s.offset);
  const settle = () => {
    for (let i = 0; i < waiting.length; ) {
      const w = waiting[i];
      if (failure) w.reject(failure);
      else if (ready(w.start, w.end)) w.resolve(file!.subarray(w.start, Math.min(w.end, file!.length)));
      else {
        i++;
        continue;
      }
      waiting.splice(i, 1);
    }
  };
  const src: ByteSource = {
    name,
    total: null,
    notice: null,
    read(start, end) {
      return new Promise((resolve, reject) => {
        waiting.push({ start, end, resolve, reject });
        settle();
      });
    },
  };

  const run = async () => {
    const download = new Download((await open()).getReader(), onBytes);
    try {
      const h0 = await download.take(PACKED_HEAD_SIZE, `${PACKED_HEAD_SIZE}-byte head`);
      if (PACKED_MAGIC.some((b, i) => h0[i] !== b)) throw new CgcError('not a packed .cgc file (bad magic bytes; a .cgc is opened by its own name)');
      const v = new DataView(h0.buffer, h0.byteOffset, PACKED_HEAD_SIZE);
      // First, since the version sets the layout of the rest (a version 1 head is 48 bytes).
      if (v.getUint32(8, true) !== PACKED_VERSION) {
        throw new CgcError(`packed format version ${v.getUint32(8, true)}; this viewer reads version ${PACKED_VERSION} (pack the .cgc again with this isogrid)`, true);
      }
      const headLength = v.getUint32(12, true);
      const cgcLength = Number(v.getBigUint64(16, true));
      const streamLength = Number(v.getBigUint64(24, true));
      const preambleLength = Number(v.getBigUint64(32, true));
      const codedLength = Number(v.getBigUint64(40, true));
      if (headLength < HEADER_SIZE || headLength > HEADER_SIZE + 64 * TABLE_ENTRY_SIZE || (headLength - HEADER_SIZE) % TABLE_ENTRY_SIZE) {
        throw new CgcError(`packed head gives a ${headLength}-byte .cgc head (damaged)`);
      }
      const head = await download.take(headLength, `${PACKED_HEAD_SIZE + headLength}-byte head`);
      if (new Crc32().update(h0.subarray(0, 48)).update(head).digest() !== v.getUint32(48, true)) {
        throw new CgcError('packed head checksum mismatch (the head is damaged)');
      }
      // Bounds on the lengths, so that a crafted head cannot ask for a giant allocation: deflate
      // expands at most 1032-fold, and a .cgc is far less than 65536 times the packed bytes that
      // rebuild it (a coded bit, at best about 1/300 of a bit, stands for at most a cell: 8
      // records of 32 B and a 12 B slot).
      if (preambleLength > 1032 * streamLength + 64 || cgcLength > 65536 * (streamLength + codedLength) + headLength + 4096) {
        throw new CgcError('packed head gives lengths no packed file can have (damaged)');
      }
      if (v.getUint32(52, true) !== 0) throw new CgcError('packed head has reserved bytes set (damaged)');
      const h = parseHeader(head, cgcLength);
      if (h.sections.some((s) => s.kind > SECTION_WORLD_FRAME)) throw new CgcError('a packed file holds no section of an unknown kind (damaged)');
      if (HEADER_SIZE + h.sections.length * TABLE_ENTRY_SIZE !== headLength) throw new CgcError('packed head and section table disagree (damaged)');
      const total = PACKED_HEAD_SIZE + headLength + streamLength + codedLength;
      download.setTotal(total);
      header = h;
      file = new Uint8Array(cgcLength);
      file.set(head);
      for (const s of h.sections) filled.set(s, 0);
      src.total = cgcLength;
      settle();

      const preamble = new Preamble(await inflate(await download.take(streamLength), preambleLength));
      await rebuild(h, file, preamble, download, codedLength, filled, settle);
      await download.end();
      complete = true;
      settle();
    } catch (e) {
      download.cancel();
      throw e;
    }
  };
  run().catch((e) => {
    failure = e instanceof CgcError || e instanceof Error ? e : new CgcError(String(e));
    settle();
  });
  return src;
}

/**
 * Rebuilds every section of `file` after its head from the inflated `preamble` and the
 * `codedLength` bytes of chunks that follow it in `download` (pack.rs).
 */
async function rebuild(
  h: CgcHeader,
  file: Uint8Array,
  body: Preamble,
  download: Download,
  codedLength: number,
  filled: Map<Section, number>,
  settle: () => void,
): Promise<void> {
  const nb = blockDims(h);
  const blockCount = h.blockCount;
  if (blockCount !== nb[0] * nb[1] * nb[2]) throw new CgcError('block count does not match the dims (damaged)');
  const bpc = h.precisionBits; // bytes per corner record
  const bits = h.precisionBits;
  const max = 2 ** bits - 1;

  // Blocks: their value bounds, then cluster counts.
  const bounds = body.bytes(8 * blockCount);
  const bv = new DataView(file.buffer, file.byteOffset + h.blocks.offset, h.blocks.length);
  const clusters: number[] = [];
  let slots = 0;
  for (let i = 0; i < blockCount; i++) {
    const n = body.varint();
    if (16 * (slots / 16 + n) > h.slotCount) throw new CgcError('the packed blocks hold more clusters than the header counts (damaged)');
    clusters.push(n);
    bv.setUint32(BLOCK_BYTES * i, 16 * n, true);
    bv.setUint32(BLOCK_BYTES * i + 4, slots, true);
    file.set(bounds.subarray(8 * i, 8 * i + 8), h.blocks.offset + BLOCK_BYTES * i + 8);
    slots += 16 * n;
  }
  if (slots !== h.slotCount) throw new CgcError('the packed blocks hold fewer clusters than the header counts (damaged)');
  filled.set(h.blocks, h.blocks.length);
  const attr = h.attribute;
  let width = 0;
  if (attr) {
    const head = body.bytes(ATTRIBUTE_HEAD_SIZE);
    width = new DataView(head.buffer, head.byteOffset, ATTRIBUTE_HEAD_SIZE).getUint32(4, true) / 8;
    if (![1, 2, 4].includes(width) || attr.length !== ATTRIBUTE_HEAD_SIZE + width * h.activeCells) throw new CgcError('the packed attribute head does not match its section (damaged)');
    file.set(head, attr.offset);
    filled.set(attr, ATTRIBUTE_HEAD_SIZE);
  }
  // The label sections as they are (streamCgc checks them).
  for (const s of h.labels ?? []) {
    file.set(body.bytes(s.length), s.offset);
    filled.set(s, s.length);
  }
  // The world frame section as it is.
  if (h.worldFrame) {
    file.set(body.bytes(h.worldFrame.length), h.worldFrame.offset);
    filled.set(h.worldFrame, h.worldFrame.length);
  }
  body.end();
  const clusterLabels = h.labels ? new DataView(file.buffer, file.byteOffset + h.labels[0].offset, h.labels[0].length) : null;
  settle();
  const models = new BlockModels(bits, width);
  let chunk: RangeDecoder | null = null;
  let chunkBlocks = 0;
  const codedStart = download.taken;
  let blocksLeft = clusters.filter((n) => n > 0).length;
  let previousMode = 0;
  const previousValue = [0, 0, 0, 0];

  const m = new DataView(file.buffer, file.byteOffset + h.metacells.offset, h.metacells.length);
  const cells = file.subarray(h.cells.offset, h.cells.offset + h.cells.length);
  const cv = new DataView(cells.buffer, cells.byteOffset, cells.byteLength);
  const boxes = new Map<number, Float64Array>();
  const order: number[] = [];
  const spare: Float64Array[] = []; // boxes no later block reaches, to be used again
  const reach = nb[0] * nb[1] + nb[0] + 1;
  let slot = 0;
  let cell = 0;
  const cellAt: number[] = []; // block-local sample index of each cell's corner 0, in record order
  const cellGroup: number[] = []; // each cell's group
  /** One label's samples in the block (the whole block's in a file without labels): pack.rs's Group. */
  /**
   * `needed` marks the samples its cells have as corners, one 17-bit mask of x per sample row
   * (index z·17 + y): the new samples are then found by visiting the marked ones, not the box.
   */
  type Group = { label: number; known: Float64Array; needed: Uint32Array };
  const groups: Group[] = [];
  const spareNeeded: Uint32Array[] = [];
  /** A box of block `index` with every sample its earlier neighbours sent (files without labels). */
  const seeded = (index: number): Float64Array => {
    while (order.length && order[0] + reach < index) {
      const done = order.shift()!;
      spare.push(boxes.get(done)!);
      boxes.delete(done);
    }
    const known = (spare.pop() ?? new Float64Array(BOX)).fill(-1);
    const b = [index % nb[0], Math.floor(index / nb[0]) % nb[1], Math.floor(index / (nb[0] * nb[1]))];
    for (let dz = -1; dz <= 1; dz++) {
      for (let dy = -1; dy <= 1; dy++) {
        for (let dx = -1; dx <= 1; dx++) {
          const n = [b[0] + dx, b[1] + dy, b[2] + dz];
          if (n.some((v, a) => v < 0 || v >= nb[a])) continue;
          const ni = n[0] + nb[0] * (n[1] + nb[1] * n[2]);
          const other = ni < index ? boxes.get(ni) : undefined;
          if (!other) continue;
          const span = (d: number) => (d === -1 ? [0, 1] : d === 0 ? [0, SIDE] : [BLOCK_CELLS, SIDE]);
          const [z0, z1] = span(dz);
          const [y0, y1] = span(dy);
          const [x0, x1] = span(dx);
          for (let z = z0; z < z1; z++) {
            for (let y = y0; y < y1; y++) {
              for (let x = x0; x < x1; x++) {
                const val = other[(z - BLOCK_CELLS * dz) * SIDE * SIDE + (y - BLOCK_CELLS * dy) * SIDE + (x - BLOCK_CELLS * dx)];
                if (val >= 0) known[z * SIDE * SIDE + y * SIDE + x] = val;
              }
            }
          }
        }
      }
    }
    return known;
  };
  let worked = performance.now();
  for (let index = 0; index < blockCount; index++) {
    if (clusters[index] === 0) continue;
    // The rebuild runs on the page's thread: every few milliseconds it lets the page draw and
    // take input (awaiting bytes already inflated would never leave the microtask queue).
    if (performance.now() - worked > YIELD_MS) {
      await yieldToPage();
      worked = performance.now();
    }
    if (chunkBlocks === 0) {
      // The next chunk, whole: its block count and length, then its coded bytes.
      chunkBlocks = await download.varint();
      const length = await download.varint();
      if (chunkBlocks < 1 || chunkBlocks > blocksLeft) throw new CgcError(`a packed chunk of ${chunkBlocks} blocks where ${blocksLeft} are left (damaged)`);
      if (download.taken - codedStart + length > codedLength) throw new CgcError('a packed chunk runs past the block stream its head gives (damaged)');
      chunk = new RangeDecoder(await download.take(length));
    }
    const d = chunk!;
    const b = [index % nb[0], Math.floor(index / nb[0]) % nb[1], Math.floor(index / (nb[0] * nb[1]))];
    for (const g of groups.splice(0)) {
      if (clusterLabels) spare.push(g.known);
      spareNeeded.push(g.needed);
    }
    // Metacells and cluster bounds; which samples each group needs.
    cellAt.length = 0;
    cellGroup.length = 0;
    const firstCell = cell;
    let previous = -1;
    let stepContext = 0;
    let previousMask = 0;
    const origin = b.map((v) => (v * BLOCK_CELLS) / 2);
    for (let k = 0; k < clusters[index]; k++) {
      const label = clusterLabels ? clusterLabels.getUint32(4 * (slot / CLUSTER_SLOTS), true) : 0;
      let gi = groups.findIndex((g) => g.label === label);
      if (gi < 0) {
        // As in pack.rs: samples are shared across blocks without labels; with labels a block's
        // groups start from none known.
        const known = clusterLabels ? (spare.pop() ?? new Float64Array(BOX)).fill(-1) : seeded(index);
        groups.push({ label, known, needed: (spareNeeded.pop() ?? new Uint32Array(SIDE * SIDE)).fill(0) });
        gi = groups.length - 1;
      }
      const needed = groups[gi].needed;
      const count = models.counts.decode(d, 0);
      if (count < 1 || count > CLUSTER_METACELLS) throw new CgcError(`a packed cluster of ${count} metacells (damaged)`);
      const lo = [Infinity, Infinity, Infinity];
      const hi = [-1, -1, -1];
      for (let s = 0; s < count; s++) {
        const step = models.steps.decode(d, stepContext);
        stepContext = 1 + Math.min(bitLength(step), 11);
        const code = previous + (step % 2 ? -(step + 1) / 2 : step / 2);
        if (code < 0 || code >= 512) throw new CgcError('a packed metacell lies outside its block (damaged)');
        previous = code;
        const mask = models.masks.decode(d, previousMask);
        previousMask = mask;
        if (mask === 0) throw new CgcError('a packed metacell has no active cell (damaged)');
        const local = mortonDecode(code);
        const at = SLOT_BYTES * (slot + s);
        for (let a = 0; a < 3; a++) {
          const pos = origin[a] + local[a];
          m.setUint16(at + 2 * a, pos, true);
          lo[a] = Math.min(lo[a], pos);
          hi[a] = Math.max(hi[a], pos);
        }
        m.setUint16(at + 6, mask, true);
        m.setUint32(at + 8, cell + cellAt.length, true);
        for (let bit = 0; bit < 8; bit++) {
          if (!(mask & (1 << bit))) continue;
          // The cell's low corner, in block-local samples; its corners span two x in four rows.
          const x = 2 * local[0] + (bit & 1);
          const row = (2 * local[2] + (bit >> 2)) * SIDE + 2 * local[1] + ((bit >> 1) & 1);
          cellAt.push(row * SIDE + x);
          cellGroup.push(gi);
          const xs = 3 << x;
          needed[row] |= xs;
          needed[row + 1] |= xs;
          needed[row + SIDE] |= xs;
          needed[row + SIDE + 1] |= xs;
        }
      }
      const bound = SLOT_BYTES * (slot + BOUND_SLOT);
      for (let a = 0; a < 3; a++) {
        m.setUint16(bound + 2 * a, lo[a], true);
        m.setUint16(bound + 6 + 2 * a, hi[a], true);
      }
      slot += CLUSTER_SLOTS;
    }
    if (cell + cellAt.length > h.activeCells) throw new CgcError('the packed cells outnumber the header\'s active cells (damaged)');
    // Each group's new samples, in the order of their first cluster.
    for (const { known, needed } of groups) {
      let last = Math.floor((max + 1) / 2);
      // The predictor (pack.rs), except at 1 bit per corner.
      const mode = bits > 1 ? models.modes.decode(d, previousMode) : 0;
      previousMode = mode;
      let previousLength = 0;
      // The marked samples in z, y, x order: rows in order, each row's x from its lowest bit.
      for (let row = 0; row < SIDE * SIDE; row++) {
        const z = Math.floor(row / SIDE);
        const y = row - z * SIDE;
        for (let xs = needed[row]; xs !== 0; xs &= xs - 1) {
          const x = 31 - Math.clz32(xs & -xs);
          const at = row * SIDE + x;
          if (known[at] >= 0) continue;
          const u = models.residuals.decode(d, residualContext(previousLength, neighbourSpread(known, at, x, y, z)));
          if (u > max) throw new CgcError('a packed sample is out of range (damaged)');
          previousLength = bitLength(u);
          const residual = unfoldResidual(u, max);
          // Modulo max + 1 of a sum of two codes, as one subtraction (`%` of doubles is slow).
          let val = predict(known, x, y, z, max, last, mode) + residual;
          if (val > max) val -= max + 1;
          known[at] = val;
          last = val;
        }
      }
    }
    // Corner records.
    for (let i = 0; i < cellAt.length; i++) {
      const r = (cell + i) * bpc;
      const known = groups[cellGroup[i]].known;
      for (let q = 0; q < 8; q++) {
        const val = known[cellAt[i] + CORNER_OFFSETS[q]];
        if (bits === 1) cells[r] |= val << q;
        else if (bits === 4) cells[r + (q >> 1)] |= val << (4 * (q & 1));
        else if (bits === 8) cells[r + q] = val;
        else if (bits === 16) cv.setUint16(r + 2 * q, val, true);
        else cv.setUint32(r + 4 * q, val, true);
      }
    }
    cell += cellAt.length;
    if (attr) {
      let at = attr.offset + ATTRIBUTE_HEAD_SIZE + width * firstCell;
      for (let i = firstCell; i < cell; i++) {
        for (let lane = 0; lane < width; lane++) {
          const byte = models.attribute.decode(d, lane * 256 + previousValue[lane]);
          previousValue[lane] = byte;
          file[at++] = byte;
        }
      }
    }
    blocksLeft--;
    if (--chunkBlocks === 0 && !d.finished) throw new CgcError('a packed chunk has bytes left over (damaged)');
    if (!clusterLabels) {
      boxes.set(index, groups[0].known);
      order.push(index);
    }
    filled.set(h.metacells, SLOT_BYTES * slot);
    filled.set(h.cells, bpc * cell);
    if (attr) filled.set(attr, ATTRIBUTE_HEAD_SIZE + width * cell);
    settle();
  }
  if (cell !== h.activeCells) throw new CgcError('the packed cells are fewer than the header\'s active cells (damaged)');
  const coded = download.taken - codedStart;
  if (coded !== codedLength) throw new CgcError(`the packed block stream is ${coded} of the ${codedLength} bytes its head gives (damaged)`);
}

/**
 * The spread (largest minus smallest) of the known samples at -1 along x, y and z of the sample
 * at box index `at`, (x, y, z): 0 with fewer than two known (pack.rs's neighbour_spread).
 */
function neighbourSpread(known: Float64Array, at: number, x: number, y: number, z: number): number {
  // Unknown samples are -1 and known ones non-negative: the spread of the known among the three.
  const a = x > 0 ? known[at - 1] : -1;
  const b = y > 0 ? known[at - SIDE] : -1;
  const c = z > 0 ? known[at - SIDE * SIDE] : -1;
  const hi = Math.max(a, b, c);
  if (hi < 0) return 0;
  const lo = Math.min(a < 0 ? hi : a, b < 0 ? hi : b, c < 0 ? hi : c);
  // With one known sample hi === lo: 0, as with none.
  return hi - lo;
}
