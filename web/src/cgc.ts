// Reading and validating .cgc files (versions 1 and 2) in the browser, rule for rule as the Rust
// reader (crates/isogrid/src/cgc/read.rs): the header and section table first (`parseHeader`), then
// each section's checksum once it is complete (`checkSection`), the zero gaps of version 2
// (`checkGaps`) and the structure of blocks, metacells and cells (`validateStructure`). The
// loader runs these as bytes arrive; `parseCgc` runs them on a whole file in the Rust reader's
// order. Errors are `CgcError`s with the Rust reader's one-line messages.
//
// Geometry: metacell positions are in metacell units (cell index / 2); cells are in index space.

import { Crc32 } from './crc32.js';
import { CORNER_PRECISION_BITS } from './colormaps.generated.js';

export const MAGIC = [0x89, 0x43, 0x47, 0x43, 0x0d, 0x0a, 0x1a, 0x0a];
export const HEADER_SIZE = 320;
const HEADER_CRC_AT = 316;
const TABLE_FIELDS_AT = 160;
export const TABLE_ENTRY_SIZE = 32;
export const MAX_SECTIONS = 64;
/// Bytes a reader takes from the start of a file to parse its header and section table.
export const HEAD_READ = HEADER_SIZE + MAX_SECTIONS * TABLE_ENTRY_SIZE;
const FLAG_REQUIRED = 1;
export const MAX_DIM = 131072;
export const BLOCK_CELLS = 16;
export const BLOCK_METACELLS = 8;
export const CLUSTER_SLOTS = 16;
export const BOUND_SLOT = 15;
export const BLOCK_BYTES = 16;
export const SLOT_BYTES = 12;

export const SECTION_BLOCKS = 1;
export const SECTION_METACELLS = 2;
export const SECTION_CELLS = 3;
export const SECTION_CELL_ATTRIBUTE = 4;
export const SECTION_CLUSTER_LABELS = 5;
export const SECTION_LABEL_INDEX = 6;
export const SECTION_LABEL_TABLE = 7;
export const SECTION_WORLD_FRAME = 8;
const KIND_NAMES: Record<number, string> = {
  1: 'blocks',
  2: 'metacells',
  3: 'cells',
  4: 'cell attribute',
  5: 'cluster labels',
  6: 'label index',
  7: 'label table',
  8: 'world frame',
};
/** The three label sections, in the order `GridLabels` reads them (`SectionKind::LABELS`). */
const LABEL_KINDS = [SECTION_CLUSTER_LABELS, SECTION_LABEL_INDEX, SECTION_LABEL_TABLE];
/** Sample types by header code (`SCALAR_CODES` in crates/isogrid/src/cgc/format.rs). */
export const SCALAR_TYPES = ['u8', 'u16', 'i16', 'f32', 'u32', 'i32', 'u64', 'i64', 'f64'];
const GRID_KINDS = [SECTION_BLOCKS, SECTION_METACELLS, SECTION_CELLS];

/** A damaged, truncated or unsupported file; `message` is one line naming the problem. */
export class CgcError extends Error {
  constructor(message: string, readonly unsupported = false) {
    super(message);
    this.name = 'CgcError';
  }
}
const corrupt = (m: string) => new CgcError(m);

export interface Section {
  name: string;
  /** Kind code (version 1: the three grid kinds). */
  kind: number;
  offset: number;
  length: number;
  crc: number;
}

export interface CgcHeader {
  version: number;
  fileLength: number;
  /** Samples per axis. */
  dims: [number, number, number];
  scalarType: number;
  spacing: [number, number, number];
  origin: [number, number, number];
  valueRange: [number, number];
  iso: number;
  precisionBits: number;
  isoCode: number;
  mappingOffset: number;
  mappingStep: number;
  blockCount: number;
  slotCount: number;
  activeCells: number;
  occupied: number;
  direction: number[][];
  blocks: Section;
  metacells: Section;
  cells: Section;
  attribute: Section | null;
  /** Cluster labels, label index and label table, when the file has labels. */
  labels: [Section, Section, Section] | null;
  /** The convention of `origin` and `direction` (`world_frame_of`), when the file names one. */
  worldFrame: Section | null;
  /** Every section in file order, each checked against its CRC once complete. */
  sections: Section[];
  /** Byte ranges [start, end) between sections that must be zero (version 2). */
  gaps: [number, number][];
}

/** Why a volume one sample thick along an axis has no surface. */
const THIN = 'the volume is one sample thick, so it has no cells';

/**
 * Why a grid with no active cell is empty, the text of the command line's note:
 * `GridInfo::empty_surface_note` of crates/isogrid for a file, whose volume is not at hand (so
 * never "every sample is NaN"), checked against vectors the Rust rule writes
 * (test/rules.generated.json). `labels`: a label grid's label values, null for an isosurface.
 */
export function emptySurfaceNote(
  h: Pick<CgcHeader, 'dims' | 'scalarType' | 'valueRange' | 'iso' | 'precisionBits'>,
  labels: bigint[] | null,
): string {
  const thin = h.dims.some((n) => n < 2);
  if (labels === null) {
    const f32 = SCALAR_TYPES[h.scalarType] === 'f32';
    const [lo, hi] = h.valueRange.map((v) => rustNumber(v, f32));
    const range = `they lie in [${lo}, ${hi}]`;
    const why = thin
      ? THIN
      : h.iso > h.valueRange[1]
        ? `every sample is below it: ${range}`
        : h.iso <= h.valueRange[0]
          ? `every sample is at or above it: ${range}`
          : `the samples lie in [${lo}, ${hi}]`;
    return `no cell crosses the isovalue ${rustNumber(h.iso, false)} (${why}); the surface is empty`;
  }
  const binary = h.precisionBits === 1;
  const why = thin
    ? THIN
    : labels.length === 0
      ? 'the volume holds no selected label'
      : binary && labels.length === 1
        ? `label ${labelText(labels[0], h.scalarType)} fills the whole volume`
        : binary
          ? 'each selected label in it fills the whole volume'
          : "after smoothing, no selected label's indicator crosses ½ in any cell";
  return `no selected label has a surface (${why}); the surface is empty`;
}

/**
 * `v` as Rust's `Display` writes an f64, or an f32 when `f32`: the shortest digits that read back
 * as the same value, never in exponent form.
 */
function rustNumber(v: number, f32: boolean): string {
  if (Object.is(v, -0)) return '-0';
  let text = v.toString();
  if (f32) {
    for (let p = 1; p <= 9; p++) {
      const t = Number(v.toPrecision(p));
      if (Math.fround(t) === v) {
        text = t.toString();
        break;
      }
    }
  }
  const m = /^(-?)(\d)(?:\.(\d+))?e([+-]\d+)$/.exec(text);
  if (!m) return text;
  const [, sign, first, rest = '', exp] = m;
  const digits = first + rest;
  const point = 1 + Number(exp);
  if (point <= 0) return `${sign}0.${'0'.repeat(-point)}${digits}`;
  if (point >= digits.length) return sign + digits + '0'.repeat(point - digits.length);
  return `${sign}${digits.slice(0, point)}.${digits.slice(point)}`;
}

export function cellDims(h: { dims: number[] }): [number, number, number] {
  return h.dims.map((n) => Math.max(n - 1, 0)) as [number, number, number];
}
export function blockDims(h: { dims: number[] }): [number, number, number] {
  return cellDims(h).map((c) => Math.ceil(c / BLOCK_CELLS)) as [number, number, number];
}
/** World bounds [lo, hi] (index × spacing; origin and direction are not applied, as natively). */
export function worldBounds(h: CgcHeader): [number[], number[]] {
  return [[0, 0, 0], [0, 1, 2].map((a) => Math.max(h.dims[a] - 1, 0) * h.spacing[a])];
}

/**
 * Whether no sample on the grid's border is inside the solid, which makes back-face culling safe
 * for an eye outside the grid box: `border_is_outside` of crates/isogrid-gpu/src/upload.rs, fed
 * cluster by cluster as they stream in. A border corner of an active cell at or above the iso code
 * settles it false; otherwise it is true once a border corner below it was seen, or, where no
 * active cell touches the border, when some border block's maximum is below the isovalue (the
 * border is then wholly outside). Until the last cluster it is the answer for the clusters so far:
 * it can only turn false as more arrive, never true again.
 */
export class BorderCheck {
  private inside = false;
  private seenOutside = false;
  private readonly blockRule: boolean;
  private readonly last: number[];

  constructor(private readonly h: CgcHeader, blocks: Uint8Array) {
    const n = blockDims(h);
    const b = new DataView(blocks.buffer, blocks.byteOffset, blocks.byteLength);
    this.last = h.dims.map((d) => Math.max(d - 1, 0));
    let rule = false;
    for (let i = 0; i < blocks.byteLength / BLOCK_BYTES && !rule; i++) {
      const p = [i % n[0], Math.floor(i / n[0]) % n[1], Math.floor(i / (n[0] * n[1]))];
      const border = p.some((v, a) => v === 0 || v + 1 === n[a]);
      rule = border && b.getFloat32(BLOCK_BYTES * i + 12, true) < h.iso;
    }
    this.blockRule = rule;
  }

  get outside(): boolean {
    return !this.inside && (this.seenOutside || this.blockRule);
  }

  /** The whole clusters of `metacells` (slots), whose records start at global record `firstCell` in `cells`. */
  add(metacells: Uint8Array, firstCell: number, cells: Uint8Array): void {
    if (this.inside) return;
    const { last } = this;
    const bits = this.h.precisionBits;
    const iso = this.h.isoCode;
    const m = new DataView(metacells.buffer, metacells.byteOffset, metacells.byteLength);
    const r = new DataView(cells.buffer, cells.byteOffset, cells.byteLength);
    const corner = (at: number, c: number): number =>
      bits === 4 ? (r.getUint8(at + (c >> 1)) >> (4 * (c & 1))) & 0xf
      : bits === 8 ? r.getUint8(at + c)
      : bits === 16 ? r.getUint16(at + 2 * c, true)
      : r.getFloat32(at + 4 * c, true);
    for (let slot = 0; slot < metacells.byteLength / SLOT_BYTES; slot++) {
      if (slot % CLUSTER_SLOTS === BOUND_SLOT) continue;
      const w0 = m.getUint32(SLOT_BYTES * slot, true);
      const w1 = m.getUint32(SLOT_BYTES * slot + 4, true);
      const mask = (w1 >>> 16) & 0xff;
      const origin = [2 * (w0 & 0xffff), 2 * (w0 >>> 16), 2 * (w1 & 0xffff)];
      let record = m.getUint32(SLOT_BYTES * slot + 8, true);
      for (let bit = 0; bit < 8; bit++) {
        if (!(mask & (1 << bit))) continue;
        // Scalars, not an array per cell: this runs for every cell of the file.
        const x = origin[0] + (bit & 1);
        const y = origin[1] + ((bit >> 1) & 1);
        const z = origin[2] + ((bit >> 2) & 1);
        if (x === 0 || y === 0 || z === 0 || x + 1 >= last[0] || y + 1 >= last[1] || z + 1 >= last[2]) {
          const cell = [x, y, z];
          const at = (record - firstCell) * bits;
          for (let c = 0; c < 8; c++) {
            const p = [cell[0] + (c & 1), cell[1] + ((c >> 1) & 1), cell[2] + ((c >> 2) & 1)];
            if (!p.some((v, a) => v === 0 || v >= last[a])) continue;
            if (corner(at, c) >= iso) {
              this.inside = true;
              return;
            }
            this.seenOutside = true;
          }
        }
        record++;
      }
    }
  }
}

/**
 * The header (and, in version 2, the section table) from `head`, the first HEAD_READ bytes of a
 * file of `fileLength` bytes (or the whole file when shorter).
 */
export function parseHeader(head: Uint8Array, fileLength: number): CgcHeader {
  if (head.length < HEADER_SIZE) {
    throw corrupt(`file is ${fileLength} bytes, shorter than the ${HEADER_SIZE}-byte .cgc header`);
  }
  const h = head.subarray(0, HEADER_SIZE);
  const after = head.subarray(HEADER_SIZE);
  if (MAGIC.some((b, i) => h[i] !== b)) throw corrupt('not a .cgc file (bad magic bytes)');
  const v = new DataView(h.buffer, h.byteOffset, HEADER_SIZE);
  const u32 = (o: number) => v.getUint32(o, true);
  const u64 = (o: number) => v.getBigUint64(o, true);
  const f64 = (o: number) => v.getFloat64(o, true);
  // The checksum first: a damaged version field is damage, not a version from the future.
  if (new Crc32().update(h.subarray(0, HEADER_CRC_AT)).digest() !== u32(HEADER_CRC_AT)) {
    throw corrupt('header checksum mismatch (the header is damaged)');
  }
  const version = u32(8);
  if (version !== 1 && version !== 2) {
    throw new CgcError(`format version ${version}; this viewer reads versions 1 and 2`, true);
  }
  if (u32(12) !== HEADER_SIZE) throw corrupt('header size field is wrong');
  const dims: [number, number, number] = [u32(16), u32(20), u32(24)];
  if (dims.some((d) => d === 0 || d > MAX_DIM)) {
    throw corrupt(`dims [${dims.join(', ')}] outside 1..=${MAX_DIM}`);
  }
  const scalarType = u32(28);
  if (scalarType >= SCALAR_TYPES.length) throw corrupt(`unknown scalar type code ${scalarType}`);
  const spacing: [number, number, number] = [f64(32), f64(40), f64(48)];
  if (spacing.some((s) => !(Number.isFinite(s) && s > 0))) {
    throw corrupt(`spacing [${spacing.join(', ')}] is not positive and finite`);
  }
  const origin: [number, number, number] = [f64(56), f64(64), f64(72)];
  const valueRange: [number, number] = [f64(80), f64(88)];
  const iso = f64(96);
  const precisionBits = u32(104);
  if (!CORNER_PRECISION_BITS.includes(precisionBits)) throw corrupt(`unknown precision ${precisionBits} bits`);
  const isoCode = v.getFloat32(108, true);
  const mappingOffset = f64(112);
  const mappingStep = f64(120);
  if (!(Number.isFinite(iso) && Number.isFinite(mappingOffset) && Number.isFinite(mappingStep) && mappingStep > 0)) {
    throw corrupt('isovalue or value mapping is not finite');
  }
  const counts = [u64(128), u64(136), u64(144)];
  const occupied = u64(152);
  const direction = [0, 1, 2].map((r) => [0, 1, 2].map((c) => f64(208 + 24 * r + 8 * c)));
  const bd = blockDims({ dims });
  const needBlocks = bd[0] * bd[1] * bd[2];
  if (counts[0] !== BigInt(needBlocks)) {
    throw corrupt(`${counts[0]} blocks stored but dims [${dims.join(', ')}] need ${needBlocks}`);
  }
  const recordSizes = [16n, 12n, BigInt(precisionBits)];
  const gridLength = (s: number, len: bigint) => {
    if (counts[s] * recordSizes[s] !== len) {
      throw corrupt(
        `${KIND_NAMES[GRID_KINDS[s]]} section is ${len} bytes but holds ${counts[s]} records of ${recordSizes[s]} bytes`,
      );
    }
  };
  const file = BigInt(fileLength);
  const fits = (name: string, offset: bigint, len: bigint, end: bigint): [number, number] => {
    // u64 arithmetic as in Rust: an offset + length past 2^64 cannot fit any file.
    if (offset % 16n !== 0n || offset < end || offset + len > file) {
      throw corrupt(`${name} section at ${offset}+${len} does not fit the ${fileLength}-byte file (truncated?)`);
    }
    return [Number(offset), Number(len)];
  };
  const grid: (Section | null)[] = [null, null, null];
  const sections: Section[] = [];
  const gaps: [number, number][] = [];
  let attribute: Section | null = null;
  let worldFrame: Section | null = null;
  const labels: (Section | null)[] = [null, null, null];
  if (version === 1) {
    let end = BigInt(HEADER_SIZE);
    for (let s = 0; s < 3; s++) {
      const offset = u64(160 + 16 * s);
      const len = u64(168 + 16 * s);
      const name = KIND_NAMES[GRID_KINDS[s]];
      gridLength(s, len);
      const [o, l] = fits(name, offset, len, end);
      end = offset + len;
      grid[s] = { name, kind: GRID_KINDS[s], offset: o, length: l, crc: u32(280 + 4 * s) };
      sections.push(grid[s]!);
    }
  } else {
    const tableAt = u64(TABLE_FIELDS_AT);
    const count = u32(168);
    const tableCrc = u32(172);
    if (h.subarray(176, 208).some((b) => b !== 0) || h.subarray(280, HEADER_CRC_AT).some((b) => b !== 0)) {
      throw corrupt('reserved header bytes are not zero');
    }
    if (tableAt !== BigInt(HEADER_SIZE) || count < 3 || count > MAX_SECTIONS) {
      throw corrupt(`section table of ${count} entries at ${tableAt} (expected 3..=${MAX_SECTIONS} at ${HEADER_SIZE})`);
    }
    const tableLength = count * TABLE_ENTRY_SIZE;
    if (after.length < tableLength) {
      throw corrupt(`the ${tableLength}-byte section table does not fit the ${fileLength}-byte file (truncated?)`);
    }
    const table = after.subarray(0, tableLength);
    if (new Crc32().update(table).digest() !== tableCrc) {
      throw corrupt('section table checksum mismatch (the table is damaged)');
    }
    const t = new DataView(table.buffer, table.byteOffset, tableLength);
    let end = BigInt(HEADER_SIZE + tableLength);
    const seen: number[] = [];
    for (let i = 0; i < count; i++) {
      const at = i * TABLE_ENTRY_SIZE;
      const kind = t.getUint32(at, true);
      const flags = t.getUint32(at + 4, true);
      const offset = t.getBigUint64(at + 8, true);
      const len = t.getBigUint64(at + 16, true);
      const crc = t.getUint32(at + 24, true);
      const known = kind in KIND_NAMES;
      const name = known ? KIND_NAMES[kind] : `section ${i} (kind ${kind})`;
      if (t.getUint32(at + 28, true) !== 0 || (flags & ~FLAG_REQUIRED) !== 0) {
        throw corrupt(`${name}: reserved table bits are set`);
      }
      const required = (flags & FLAG_REQUIRED) !== 0;
      const [o, l] = fits(name, offset, len, end);
      gaps.push([Number(end), o]);
      end = offset + len;
      const section: Section = { name, kind, offset: o, length: l, crc };
      if (!known) {
        if (required) throw new CgcError(`${name} is required, and this viewer does not know its kind`, true);
      } else {
        if (GRID_KINDS.includes(kind) !== required) throw corrupt(`${name} section has the wrong flags`);
        if (seen.includes(kind)) throw corrupt(`two ${name} sections`);
        seen.push(kind);
        const s = GRID_KINDS.indexOf(kind);
        if (s >= 0) {
          gridLength(s, len);
          grid[s] = section;
        } else if (kind === SECTION_CELL_ATTRIBUTE) {
          attribute = section;
        } else if (LABEL_KINDS.includes(kind)) {
          labels[LABEL_KINDS.indexOf(kind)] = section;
        } else if (kind === SECTION_WORLD_FRAME) {
          worldFrame = section;
        }
      }
      sections.push(section);
    }
    const missing = GRID_KINDS.find((k) => !seen.includes(k));
    if (missing !== undefined) throw corrupt(`no ${KIND_NAMES[missing]} section`);
    if (end !== file) {
      throw corrupt(`the file is ${fileLength} bytes but its sections end at ${end} (truncated or appended to?)`);
    }
    const present = labels.filter((l) => l !== null).length;
    if (present !== 0 && present !== 3) throw corrupt('the file has some of the three label sections but not all');
  }
  return {
    version,
    fileLength,
    dims,
    scalarType,
    spacing,
    origin,
    valueRange,
    iso,
    precisionBits,
    isoCode,
    mappingOffset,
    mappingStep,
    blockCount: Number(counts[0]),
    slotCount: Number(counts[1]),
    activeCells: Number(counts[2]),
    occupied: Number(occupied),
    direction,
    blocks: grid[0]!,
    metacells: grid[1]!,
    cells: grid[2]!,
    attribute,
    labels: labels[0] ? (labels as [Section, Section, Section]) : null,
    worldFrame,
    sections,
    gaps,
  };
}

/** Checks a complete section's bytes against its stored CRC-32. */
export function checkSection(section: Section, bytes: Uint8Array | Crc32): void {
  const digest = bytes instanceof Crc32 ? bytes.digest() : new Crc32().update(bytes).digest();
  if (digest !== section.crc) throw corrupt(`${section.name} section checksum mismatch (the data is damaged)`);
}

/** Checks that the bytes between sections (`gap` each) are zero. */
export function checkGaps(gaps: Uint8Array[]): void {
  if (gaps.some((g) => g.some((b) => b !== 0))) throw corrupt('padding between sections is not zero');
}

function metacellCode(x: number, y: number, z: number): number {
  const spread = (v: number) => (v & 1) | ((v & 2) << 2) | ((v & 4) << 4) | ((v & 8) << 6);
  return spread(x) | (spread(y) << 1) | (spread(z) << 2);
}

const popcount8 = (m: number) => {
  let n = 0;
  for (let b = 0; b < 8; b++) n += (m >> b) & 1;
  return n;
};

/**
 * The structure of paper §3.1, as the Rust reader checks it after the checksums: each block's
 * slots are the next whole clusters; metacells inside their block, in Morton order, before any
 * padding; cell pointers in sequence; cluster bounds exact; totals equal to the header's counts.
 * Needs the blocks and metacells; the cells only through their count (the section length).
 * Incremental: `advance(slots)` checks the blocks whose slots lie in the first `slots` slots of
 * `metacells` (the whole section's buffer, filled that far), so a streamed file is checked block
 * by block as its metacells arrive; `finish()` checks the totals.
 */
/** For each axis, the cell bits of a metacell (bit 0 +x, bit 1 +y, bit 2 +z) on its high side. */
const AXIS_HIGH_BITS = [0, 1, 2].map((a) => [0, 1, 2, 3, 4, 5, 6, 7].filter((b) => (b >> a) & 1).reduce((m, b) => m | (1 << b), 0));

export class StructureCheck {
  private blk = 0;
  /** Slots of the blocks checked so far. */
  nextSlot = 0;
  private nextCell = 0;
  private occupied = 0;
  private readonly b: DataView;
  private readonly m: DataView;

  constructor(private readonly h: CgcHeader, private readonly blocks: Uint8Array, private readonly metacells: Uint8Array) {
    this.b = new DataView(blocks.buffer, blocks.byteOffset, blocks.byteLength);
    this.m = new DataView(metacells.buffer, metacells.byteOffset, metacells.byteLength);
  }

  /** Checks the blocks whose slots are within the first `slots`; returns the slots checked. */
  advance(slots: number): number {
    const { h, b, m } = this;
    const bd = blockDims(h);
    const cd = cellDims(h);
    const totalCells = h.cells.length / h.precisionBits;
    const slotsTotal = this.metacells.byteLength / SLOT_BYTES;
    for (; this.blk < this.blocks.byteLength / BLOCK_BYTES; this.blk++) {
      const blk = this.blk;
      const count = b.getUint32(16 * blk, true);
      const pointer = b.getUint32(16 * blk + 4, true);
      if (count % CLUSTER_SLOTS !== 0 || pointer !== this.nextSlot) {
        throw corrupt(
          `block ${blk}: metacell range ${pointer}+${count} is not the next whole clusters (expected start ${this.nextSlot})`,
        );
      }
      if (pointer + count > slotsTotal) throw corrupt(`block ${blk}: metacell range runs past the metacell section`);
      if (pointer + count > slots) break;
      const pos = [blk % bd[0], Math.floor(blk / bd[0]) % bd[1], Math.floor(blk / (bd[0] * bd[1]))];
      for (let k = 0; k < count / CLUSTER_SLOTS; k++) {
        const lo = [0xffff, 0xffff, 0xffff];
        const hi = [0, 0, 0];
        let lastCode = -1;
        let padding = false;
        const first = pointer + k * CLUSTER_SLOTS;
        for (let s = 0; s < BOUND_SLOT; s++) {
          const slot = first + s;
          const at = SLOT_BYTES * slot;
          const fail = (what: string) => corrupt(`metacell slot ${slot}: ${what}`);
          const p = [m.getUint16(at, true), m.getUint16(at + 2, true), m.getUint16(at + 4, true)];
          const mask = m.getUint16(at + 6, true);
          const cellPointer = m.getUint32(at + 8, true);
          if (mask === 0) {
            if (p.some((x) => x !== 0) || cellPointer !== 0) throw fail('empty slot with non-zero fields');
            padding = true;
            continue;
          }
          if (padding || mask > 0xff) throw fail('metacell after padding, or reserved mask bits set');
          for (let a = 0; a < 3; a++) {
            if (Math.floor(p[a] / BLOCK_METACELLS) !== pos[a]) throw fail('position outside its block');
          }
          const code = metacellCode(p[0] % BLOCK_METACELLS, p[1] % BLOCK_METACELLS, p[2] % BLOCK_METACELLS);
          if (lastCode >= code) throw fail('metacells out of Morton order');
          lastCode = code;
          // The cells of the mask past the grid's last cell on some axis: all of them where the
          // metacell's low cell is past it, those with the axis's bit set where its high one is.
          let outside = 0;
          for (let a = 0; a < 3; a++) {
            if (2 * p[a] >= cd[a]) outside = 0xff;
            else if (2 * p[a] + 1 >= cd[a]) outside |= AXIS_HIGH_BITS[a];
          }
          if (mask & outside) throw fail('active cell outside the grid');
          if (cellPointer !== this.nextCell) throw fail(`cell pointer ${cellPointer} out of sequence (expected ${this.nextCell})`);
          this.nextCell += popcount8(mask);
          if (this.nextCell > totalCells) throw fail('cells run past the cell section');
          this.occupied++;
          for (let a = 0; a < 3; a++) {
            lo[a] = Math.min(lo[a], p[a]);
            hi[a] = Math.max(hi[a], p[a]);
          }
        }
        const at = SLOT_BYTES * (first + BOUND_SLOT);
        const bound = [0, 1, 2, 3, 4, 5].map((i) => m.getUint16(at + 2 * i, true));
        const firstMask = m.getUint16(SLOT_BYTES * first + 6, true);
        if (firstMask === 0 || bound.slice(0, 3).some((x, a) => x !== lo[a]) || bound.slice(3).some((x, a) => x !== hi[a])) {
          throw corrupt(`cluster bound in slot ${first + BOUND_SLOT} does not match its metacells`);
        }
      }
      this.nextSlot += count;
    }
    return this.nextSlot;
  }

  /** The totals, once every block is checked. */
  finish(): void {
    const slotsTotal = this.metacells.byteLength / SLOT_BYTES;
    const totalCells = this.h.cells.length / this.h.precisionBits;
    if (this.nextSlot !== slotsTotal || this.nextCell !== totalCells || this.occupied !== this.h.occupied) {
      throw corrupt("blocks, metacells and cells do not add up to the header's counts");
    }
  }
}

/** The whole structure check of a file whose blocks and metacells are complete. */
export function validateStructure(h: CgcHeader, blocks: Uint8Array, metacells: Uint8Array): void {
  const check = new StructureCheck(h, blocks, metacells);
  check.advance(metacells.byteLength / SLOT_BYTES);
  check.finish();
}

// ---- The world frame (kind 8; `world_frame_of` in crates/isogrid/src/cgc/format.rs) ----

/** The patient-space convention of a file's origin and directions. */
export type WorldFrame = 'LPS' | 'RAS';

/** The convention a world frame section names: a u32 code (1 LPS, 2 RAS), then 4 zero bytes. */
export function parseWorldFrame(bytes: Uint8Array): WorldFrame {
  const code = bytes.length === 8 && bytes.subarray(1).every((b) => b === 0) ? bytes[0] : 0;
  if (code === 1) return 'LPS';
  if (code === 2) return 'RAS';
  throw corrupt('world frame section is not an LPS (1) or RAS (2) code');
}

/**
 * Whether the i, j, k axes of `direction` (rows) are a mirror image of x, y, z (a negative
 * determinant): `directions_mirror` of crates/isogrid, checked against its vectors
 * (test/rules.generated.json). Such a grid is drawn by mirrored cameras, so that the picture shows
 * its world as it lies rather than left and right swapped.
 */
export function directionsMirror(direction: number[][]): boolean {
  const [a, b, c] = direction;
  const det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
  return det < 0;
}

// ---- The cell attribute (kind 4; crates/isogrid/src/attribute.rs) ----

/** Bytes of the head of an attribute section. */
export const ATTRIBUTE_HEAD_SIZE = 96;
const ATTRIBUTE_NAME_SIZE = 64;

/** What an attribute is: `AttributeInfo` (name, bits per value, finite range). */
export interface AttributeInfo {
  name: string;
  /** 8 or 16 (codes over the range) or 32 (f32 as it is). */
  bits: number;
  /** Smallest and largest finite value, in the attribute's units (`[0, 0]` when none is). */
  range: [number, number];
}

/** An attribute's values: one per active cell, in corner-record order, as the section stores them. */
export interface CellAttribute {
  info: AttributeInfo;
  values: Uint8Array;
}

const utf8 = new TextDecoder('utf-8', { fatal: true });
const text = (b: Uint8Array): string | null => {
  try {
    return utf8.decode(b);
  } catch {
    return null;
  }
};

/**
 * The head of an attribute section (its first ATTRIBUTE_HEAD_SIZE bytes), checked as
 * `AttributeInfo::from_head` does, and the value count it gives.
 */
export function parseAttributeHead(bytes: Uint8Array): { info: AttributeInfo; count: bigint } {
  if (bytes.length < ATTRIBUTE_HEAD_SIZE) throw corrupt('cell attribute section is shorter than its head');
  const v = new DataView(bytes.buffer, bytes.byteOffset, ATTRIBUTE_HEAD_SIZE);
  const perCell = v.getUint32(0, true);
  if (perCell !== 1) throw corrupt(`cell attribute has ${perCell} values per cell; 1 is defined`);
  const bits = v.getUint32(4, true);
  if (![8, 16, 32].includes(bits)) throw corrupt(`cell attribute of ${bits} bits per value`);
  const range: [number, number] = [v.getFloat64(8, true), v.getFloat64(16, true)];
  if (!(Number.isFinite(range[0]) && Number.isFinite(range[1]) && range[0] <= range[1])) {
    throw corrupt(`cell attribute range [${range.join(', ')}] is not finite and ordered`);
  }
  const count = v.getBigUint64(24, true);
  const field = bytes.subarray(32, 32 + ATTRIBUTE_NAME_SIZE);
  const nameLength = field.indexOf(0) < 0 ? ATTRIBUTE_NAME_SIZE : field.indexOf(0);
  if (field.subarray(nameLength).some((b) => b !== 0)) throw corrupt('cell attribute name is not zero-padded');
  const name = text(field.subarray(0, nameLength));
  if (name === null) throw corrupt('cell attribute name is not UTF-8');
  return { info: { name, bits, range }, count };
}

/** The cell attribute in `bytes` (its whole section), checked as `parse_attribute` (cgc/read.rs) does. */
export function parseAttribute(bytes: Uint8Array, activeCells: number): CellAttribute {
  const { info, count } = parseAttributeHead(bytes);
  const { bits, range } = info;
  const values = bytes.subarray(ATTRIBUTE_HEAD_SIZE);
  if (count !== BigInt(activeCells) || BigInt(values.length) !== count * BigInt(bits / 8)) {
    throw corrupt(
      `cell attribute section holds ${values.length} bytes of values, and ${count} values for ${activeCells} active cells`,
    );
  }
  if (bits === 32) {
    const f = new DataView(values.buffer, values.byteOffset, values.byteLength);
    for (let i = 0; i < activeCells; i++) {
      const x = f.getFloat32(4 * i, true);
      if (!Number.isNaN(x) && !(x >= range[0] && x <= range[1])) {
        throw corrupt(`cell attribute value ${x} lies outside its range [${range[0]}, ${range[1]}]`);
      }
    }
  }
  return { info, values };
}

/** How stored codes become values: `zero + code × step`, and `nanCode` is NaN (`CodeMapping`). */
export interface CodeMapping {
  zero: number;
  step: number;
  nanCode: number;
}

/**
 * The mapping of the 16-bit codes `codesOf` gives (`AttributeInfo::code_mapping` of 8- and 16-bit
 * codes; f32 values are coded at 16 bits).
 */
export function codeMapping(info: AttributeInfo): CodeMapping {
  const [lo, hi] = info.range;
  const nanCode = 2 ** (info.bits === 8 ? 8 : 16) - 1;
  return { zero: lo, step: (hi - lo) / (nanCode - 1), nanCode };
}

/**
 * Stored values (`values`: whole values of the section, any run of them) as 16-bit codes, as the
 * native renderer uploads them (2 bytes per cell): `CellAttribute::codes16`, with
 * `AttributeInfo::encode` at 16 bits for f32 values. Checked against the Rust rule by
 * web/test/cgc.test.mjs (vectors generated from Rust).
 */
export function codesOf(info: AttributeInfo, values: Uint8Array): Uint16Array {
  const [lo, hi] = info.range;
  const top = codeMapping(info).nanCode - 1;
  const n = values.length / (info.bits / 8);
  const codes = new Uint16Array(n);
  const v = new DataView(values.buffer, values.byteOffset, values.byteLength);
  if (info.bits === 8) {
    codes.set(values);
  } else if (info.bits === 16) {
    for (let i = 0; i < n; i++) codes[i] = v.getUint16(2 * i, true);
  } else {
    for (let i = 0; i < n; i++) {
      const x = v.getFloat32(4 * i, true);
      codes[i] = Number.isNaN(x) ? top + 1 : hi > lo ? Math.round(Math.min(Math.max((x - lo) / (hi - lo), 0), 1) * top) : 0;
    }
  }
  return codes;
}

/** A whole attribute's codes and their mapping. */
export function codes16(a: CellAttribute): { codes: Uint16Array; mapping: CodeMapping } {
  return { codes: codesOf(a.info, a.values), mapping: codeMapping(a.info) };
}

// ---- Labels (kinds 5, 6, 7; crates/isogrid/src/labels.rs) ----

const LABEL_HEAD_SIZE = 16;
const LABEL_INDEX_ENTRY_SIZE = 48;
const LABEL_RUN_SIZE = 8;
const LABEL_TABLE_ENTRY_SIZE = 16;

/** One label of a table (`Label`). */
export interface Label {
  /** The label value as a u64 key (a signed volume's value as its two's complement). */
  value: bigint;
  name: string;
  /** sRGB red, green, blue and alpha. */
  rgba: [number, number, number, number];
}

/** A label's entry in the label index (`LabelEntry`): cells, cell box `[lo, hi)` (index space), runs. */
export interface LabelEntry {
  cellCount: number;
  firstRun: number;
  runCount: number;
  lo: [number, number, number];
  hi: [number, number, number];
}

/** The labels of a grid (`GridLabels`). */
export interface GridLabels {
  table: Label[];
  /** Label-table index of every cluster. */
  clusterLabels: Uint32Array;
  index: LabelEntry[];
  /** Runs of one label's consecutive clusters: first cluster, cluster count (pairs). */
  runs: Uint32Array;
}

/** How label value `key` is shown: signed when the volume's type is (`labels::display_value`). */
export function labelText(key: bigint, scalarType: number): string {
  return (SCALAR_TYPES[scalarType].startsWith('u') ? key : BigInt.asIntN(64, key)).toString();
}

/**
 * The three label sections parsed and checked against the grid's metacell slots, rule for rule
 * and message for message as `GridLabels::from_sections` and `GridLabels::check`: lengths against
 * their counts before anything is allocated, values strictly increasing, names UTF-8, cluster
 * labels in range, each label's runs following the previous label's in cluster order and holding
 * only its clusters, all runs covering every cluster once, cell counts and boxes exact.
 */
export function parseLabels(clusters: Uint8Array, index: Uint8Array, table: Uint8Array, metacells: Uint8Array): GridLabels {
  const labels = readLabels(clusters, index, table, metacells.length / SLOT_BYTES / CLUSTER_SLOTS);
  checkLabels(labels, metacells);
  return labels;
}

/**
 * The three label sections parsed for a grid of `clusterCount` clusters, with every check of
 * `parseLabels` that needs no metacells (lengths, values, names, cluster labels in range); the
 * loader colours clusters with them before the metacells have arrived, and `checkLabels` then.
 */
export function readLabels(clusters: Uint8Array, index: Uint8Array, table: Uint8Array, clusterCount: number): GridLabels {
  const view = (b: Uint8Array) => new DataView(b.buffer, b.byteOffset, b.byteLength);
  // The table.
  if (table.length < LABEL_HEAD_SIZE) throw corrupt('label table section is shorter than its head');
  const tv = view(table);
  const n64 = tv.getBigUint64(0, true);
  const nameBytes = tv.getBigUint64(8, true);
  // u64 arithmetic with overflow checks, as in Rust: an overflow cannot equal a section's length.
  const limit = 1n << 64n;
  const expectedTable = n64 * BigInt(LABEL_TABLE_ENTRY_SIZE) + BigInt(LABEL_HEAD_SIZE) + nameBytes;
  if (expectedTable >= limit || n64 * BigInt(LABEL_TABLE_ENTRY_SIZE) >= limit || expectedTable !== BigInt(table.length)) {
    throw corrupt(`label table section is ${table.length} bytes, not the head, ${n64} entries and ${nameBytes} name bytes`);
  }
  const n = Number(n64);
  let nameAt = LABEL_HEAD_SIZE + LABEL_TABLE_ENTRY_SIZE * n;
  const labels: Label[] = [];
  for (let i = 0; i < n; i++) {
    const e = LABEL_HEAD_SIZE + LABEL_TABLE_ENTRY_SIZE * i;
    const value = tv.getBigUint64(e, true);
    const len = tv.getUint32(e + 12, true);
    if (labels.length && labels[labels.length - 1].value >= value) {
      throw corrupt(`label table entry ${i}: values are not strictly increasing`);
    }
    if (len > table.length - nameAt) throw corrupt(`label table entry ${i}: its name runs past the names`);
    const name = text(table.subarray(nameAt, nameAt + len));
    if (name === null) throw corrupt(`label table entry ${i}: name is not UTF-8`);
    nameAt += len;
    labels.push({ value, name, rgba: [table[e + 8], table[e + 9], table[e + 10], table[e + 11]] });
  }
  if (nameAt !== table.length) throw corrupt('label table names are longer than its entries say');

  // Cluster labels.
  if (clusters.length !== clusterCount * 4) {
    throw corrupt(`cluster label section is ${clusters.length} bytes for ${clusterCount} clusters`);
  }
  const cv = view(clusters);
  const clusterLabels = new Uint32Array(clusterCount);
  for (let c = 0; c < clusterCount; c++) {
    clusterLabels[c] = cv.getUint32(4 * c, true);
    if (clusterLabels[c] >= n) throw corrupt(`cluster ${c} has label ${clusterLabels[c]} of ${n}`);
  }

  // The index.
  if (index.length < LABEL_HEAD_SIZE || view(index).getBigUint64(0, true) !== n64) {
    throw corrupt(`label index section does not start with the table's ${n} labels`);
  }
  const iv = view(index);
  const runTotal = iv.getBigUint64(8, true);
  const expectedIndex = runTotal * BigInt(LABEL_RUN_SIZE) + BigInt(LABEL_HEAD_SIZE + LABEL_INDEX_ENTRY_SIZE * n);
  if (runTotal * BigInt(LABEL_RUN_SIZE) >= limit || expectedIndex >= limit || expectedIndex !== BigInt(index.length)) {
    throw corrupt(`label index section is ${index.length} bytes, not the head, ${n} entries and ${runTotal} runs`);
  }
  const entries: LabelEntry[] = [];
  for (let i = 0; i < n; i++) {
    const e = LABEL_HEAD_SIZE + LABEL_INDEX_ENTRY_SIZE * i;
    // Counts past 2^53 cannot be right for any file a browser holds; kept as NaN-free numbers.
    const big = (o: number) => iv.getBigUint64(e + o, true);
    entries.push({
      cellCount: Number(big(0)),
      firstRun: Number(big(8)),
      runCount: Number(big(16)),
      lo: [0, 1, 2].map((a) => iv.getUint32(e + 24 + 4 * a, true)) as [number, number, number],
      hi: [0, 1, 2].map((a) => iv.getUint32(e + 36 + 4 * a, true)) as [number, number, number],
    });
  }
  const runsAt = LABEL_HEAD_SIZE + LABEL_INDEX_ENTRY_SIZE * n;
  const runCount = Number(runTotal);
  const runs = new Uint32Array(2 * runCount);
  for (let j = 0; j < 2 * runCount; j++) runs[j] = iv.getUint32(runsAt + 4 * j, true);
  return { table: labels, clusterLabels, index: entries, runs };
}

/** `GridLabels::check`: the index against the cluster labels and the metacells. */
export function checkLabels(g: GridLabels, metacells: Uint8Array): void {
  const m = new DataView(metacells.buffer, metacells.byteOffset, metacells.byteLength);
  const clusterCount = metacells.length / SLOT_BYTES / CLUSTER_SLOTS;
  const fail = (i: number, what: string) => corrupt(`label index entry ${i}: ${what}`);
  if (g.table.length !== g.index.length || g.clusterLabels.length !== clusterCount) {
    throw corrupt('label sections disagree on the number of labels or clusters');
  }
  const runCount = g.runs.length / 2;
  // Metacell::cell_box: the low cell of an axis is present when a cell bit with that axis's bit 0 is.
  const LOW = [0x55, 0x33, 0x0f];
  let nextRun = 0;
  let covered = 0;
  g.index.forEach((e, i) => {
    if (e.firstRun !== nextRun || e.runCount > runCount - nextRun) throw fail(i, "its runs do not follow the previous label's");
    nextRun += e.runCount;
    let cells = 0;
    let lo = [0xffffffff, 0xffffffff, 0xffffffff];
    const hi = [0, 0, 0];
    let end = 0;
    for (let r = e.firstRun; r < nextRun; r++) {
      const first = g.runs[2 * r];
      const count = g.runs[2 * r + 1];
      if (count === 0 || first < end || first + count > clusterCount) throw fail(i, 'a run is empty, out of order or outside the grid');
      end = first + count;
      covered += count;
      for (let c = first; c < end; c++) {
        if (g.clusterLabels[c] !== i) throw fail(i, `cluster ${c} in its runs has another label`);
        for (let s = 0; s < BOUND_SLOT; s++) {
          const at = SLOT_BYTES * (c * CLUSTER_SLOTS + s);
          const mask = m.getUint16(at + 6, true) & 0xff;
          if (mask === 0) continue;
          cells += popcount8(mask);
          for (let a = 0; a < 3; a++) {
            const p = 2 * m.getUint16(at + 2 * a, true);
            lo[a] = Math.min(lo[a], p + ((mask & LOW[a]) === 0 ? 1 : 0));
            hi[a] = Math.max(hi[a], p + 1 + ((mask & ~LOW[a] & 0xff) !== 0 ? 1 : 0));
          }
        }
      }
    }
    if (cells === 0) lo = [0, 0, 0];
    if (e.cellCount !== cells || e.lo.some((x, a) => x !== lo[a]) || e.hi.some((x, a) => x !== hi[a])) {
      throw fail(i, 'its cell count or bounds do not match its clusters');
    }
  });
  if (nextRun !== runCount || covered !== clusterCount) throw corrupt("the label index's runs do not cover every cluster once");
}

export interface CgcFile {
  header: CgcHeader;
  blocks: Uint8Array;
  metacells: Uint8Array;
  cells: Uint8Array;
  attribute: CellAttribute | null;
  labels: GridLabels | null;
  /** The world frame section's convention; null without one (the frame is unknown). */
  frame: WorldFrame | null;
}

/** Parses and validates a whole file in memory, in the Rust reader's order. */
export function parseCgc(bytes: Uint8Array): CgcFile {
  const header = parseHeader(bytes.subarray(0, Math.min(HEAD_READ, bytes.length)), bytes.length);
  checkGaps(header.gaps.map(([s, e]) => bytes.subarray(s, e)));
  const part = (s: Section) => bytes.subarray(s.offset, s.offset + s.length);
  for (const s of header.sections) checkSection(s, part(s));
  const blocks = part(header.blocks);
  const metacells = part(header.metacells);
  validateStructure(header, blocks, metacells);
  const attribute = header.attribute ? parseAttribute(part(header.attribute), header.activeCells) : null;
  const labels = header.labels ? parseLabels(...(header.labels.map(part) as [Uint8Array, Uint8Array, Uint8Array]), metacells) : null;
  const frame = header.worldFrame ? parseWorldFrame(part(header.worldFrame)) : null;
  return { header, blocks, metacells, cells: part(header.cells), attribute, labels, frame };
}
