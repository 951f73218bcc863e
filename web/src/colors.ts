// Surface colour for the shading pass (crates/isogrid-gpu/shaders/color.wgsl): the `ColorUniforms`
// bytes (twin: `ColorUniforms::new` in crates/isogrid-gpu/src/gpu_types.rs) and the colour data
// bound beside them — one 16-bit attribute code per corner record (COLOR_RECORDS) or each
// cluster's label albedo (COLOR_LABELS). The tables, the NaN colour and the sRGB decoding are
// generated from Rust's `isogrid::colormap` (colormaps.generated.ts); the value → entry rule lives
// in color.wgsl (`albedo_of`) only. web/test/shaders.test.mjs checks the constants and the size
// against the WGSL and Rust sources.

import { CodeMapping, GridLabels } from './cgc.js';
import { COLOR_MAPS, NAN_SRGB, SRGB8_TO_LINEAR, TABLE_SIZE } from './colormaps.generated.js';

/** The colour sources of color.wgsl. */
export const COLOR_NONE = 0;
export const COLOR_RECORDS = 1;
export const COLOR_LABELS = 3;
/** Bytes of `ColorUniforms`: mapping, params, NaN albedo, then the table's entries (vec4 each). */
export const COLOR_UNIFORMS_BYTES = 48 + 16 * TABLE_SIZE;
/** The colour maps' names, the default first (`ColorMap::ALL`). */
export const MAP_NAMES: string[] = COLOR_MAPS.map(([name]) => name);

/** Map `name`'s table: TABLE_SIZE sRGB entries, 3 bytes each. */
export function mapTable(name: string): Uint8Array {
  const hex = (COLOR_MAPS.find(([n]) => n === name) ?? COLOR_MAPS[0])[1];
  const out = new Uint8Array(3 * TABLE_SIZE);
  for (let i = 0; i < out.length; i++) out[i] = parseInt(hex.slice(2 * i, 2 * i + 2), 16);
  return out;
}

/**
 * `Coloring::default_clim`: the attribute's range, widened around its value when it is a single
 * value (checked against Rust's by web/test/cgc.test.mjs).
 */
export function defaultClim(range: [number, number]): [number, number] {
  if (range[0] < range[1]) return [range[0], range[1]];
  const half = Math.max(Math.abs(range[0]) * 1e-6, 0.5);
  return [range[0] - half, range[0] + half];
}

/** `LO,HI` with finite LO < HI (`colormap::check_clim`), else null. */
export function parseClim(s: string | null): [number, number] | null {
  const m = s?.split(',').map((x) => (x.trim() === '' ? NaN : Number(x)));
  return m && m.length === 2 && Number.isFinite(m[0]) && Number.isFinite(m[1]) && m[0] < m[1] ? [m[0], m[1]] : null;
}

export interface Coloring {
  map: string;
  clim: [number, number];
}

/**
 * The `ColorUniforms` bytes for `source`: for COLOR_RECORDS the map's table as linear albedo over
 * `coloring.clim`, codes decoded with `mapping`; COLOR_LABELS and COLOR_NONE need neither.
 */
export function colorUniforms(source: number, coloring?: Coloring, mapping?: CodeMapping): ArrayBuffer {
  const bytes = new ArrayBuffer(COLOR_UNIFORMS_BYTES);
  const f = new Float32Array(bytes);
  const u = new Uint32Array(bytes);
  u[6] = 0x7fc00000; // params.z: the bits of a quiet NaN (WGSL has no NaN constant)
  if (source === COLOR_LABELS) {
    u[4] = COLOR_LABELS;
    return bytes;
  }
  if (source !== COLOR_RECORDS || !coloring || !mapping) return bytes;
  const [lo, hi] = coloring.clim;
  f.set([mapping.zero, mapping.step, lo, 1 / (hi - lo)], 0);
  u[4] = COLOR_RECORDS;
  u[5] = mapping.nanCode;
  f.set(NAN_SRGB.map((c) => SRGB8_TO_LINEAR[c]), 8);
  const table = mapTable(coloring.map);
  for (let i = 0; i < TABLE_SIZE; i++) {
    for (let k = 0; k < 3; k++) f[12 + 4 * i + k] = SRGB8_TO_LINEAR[table[3 * i + k]];
  }
  return bytes;
}

/**
 * The label colour words `cluster_albedo` (color.wgsl) reads, as the native renderer uploads them
 * (`label_color_words`, upload.rs): word 0 the first word of the table; from word 1 each cluster's
 * label index, then one for a miss naming the table's last entry; then the table, each label's
 * albedo (`Label::albedo`: its sRGB colour decoded, f32 bits, four words), and a zero entry.
 */
export function labelColorWords(labels: GridLabels): Uint32Array {
  const clusters = labels.clusterLabels.length;
  const tableWord = 2 + clusters;
  const words = new Uint32Array(tableWord + 4 * (labels.table.length + 1));
  words[0] = tableWord;
  words.set(labels.clusterLabels, 1);
  words[1 + clusters] = labels.table.length;
  const table = new Float32Array(words.buffer, 4 * tableWord, 4 * labels.table.length);
  labels.table.forEach((l, i) => table.set([0, 1, 2].map((k) => SRGB8_TO_LINEAR[l.rgba[k]]), 4 * i));
  return words;
}

/** Per cluster, 1 where the cluster's label is hidden (`hidden`: label-table indices), via the index's runs. */
export function hiddenClusters(labels: GridLabels, hidden: Iterable<number>): Uint8Array {
  const out = new Uint8Array(labels.clusterLabels.length);
  for (const i of hidden) {
    const e = labels.index[i];
    for (let r = e.firstRun; r < e.firstRun + e.runCount; r++) {
      out.fill(1, labels.runs[2 * r], labels.runs[2 * r] + labels.runs[2 * r + 1]);
    }
  }
  return out;
}
