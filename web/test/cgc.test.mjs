// The TypeScript reader (web/src/cgc.ts, loader.ts) against real files: those written by the
// isogrid binary (the repository's fixtures, a sphere when the binary is built) and their version 2
// forms. Every truncation and every single-byte change must be refused, with the Rust reader's
// messages for the cases the page shows.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { parseCgc, CgcError, HEAD_READ, SCALAR_TYPES, codes16, directionsMirror, emptySurfaceNote, labelText } from '../build/node/cgc.js';
import { streamCgc } from '../build/node/loader.js';
import { Crc32, crc32 } from '../build/node/crc32.js';
import zlib from 'node:zlib';
import { randomBytes } from 'node:crypto';
import { defaultClim, labelColorWords, hiddenClusters } from '../build/node/colors.js';
import { realFiles, toVersion2, resealHeader, resealSection, isogridBinary, infoJson, labelFile, coloredSphereFile, ballFile, placedSphereFile } from './fixtures.mjs';

const files = realFiles();
const versions = files.flatMap(([name, bytes]) => {
  const v = new DataView(bytes.buffer, bytes.byteOffset).getUint32(8, true);
  return v === 1 ? [[name, bytes], [`${name} (as v2)`, toVersion2(bytes)]] : [[name, bytes]];
});
if (!isogridBinary()) console.log('# no isogrid binary built: testing the repository fixtures only');

/**
 * Positions to cut or change: every byte of small files; of larger ones every byte of the header
 * and table, around each section boundary, and every 97th byte (each is a full parse).
 */
function positions(bytes) {
  if (bytes.length <= 4096) return [...Array(bytes.length).keys()];
  const f = parseCgc(bytes);
  const at = new Set();
  for (let i = 0; i < HEAD_READ + 64; i++) at.add(i);
  for (const s of f.header.sections) for (const e of [s.offset, s.offset + s.length]) for (let d = -2; d <= 2; d++) at.add(e + d);
  // Every byte of the small optional sections (attribute heads, label sections).
  for (const s of f.header.sections) if (s.kind >= 4) for (let i = s.offset; i < s.offset + Math.min(s.length, 2048); i++) at.add(i);
  for (let i = 0; i < bytes.length; i += 97) at.add(i);
  return [...at].filter((i) => i >= 0 && i < bytes.length).sort((a, b) => a - b);
}

const refused = (bytes) => {
  try {
    parseCgc(bytes);
    return null;
  } catch (e) {
    if (!(e instanceof CgcError)) throw e;
    return e.message;
  }
};

test('real files parse in both versions, with the counts of their headers', () => {
  assert.ok(files.length > 0);
  for (const [name, bytes] of versions) {
    const f = parseCgc(bytes);
    const h = f.header;
    assert.equal(f.cells.length, h.activeCells * h.precisionBits, name);
    assert.equal(f.metacells.length, h.slotCount * 12, name);
    assert.ok(h.activeCells > 0 && h.occupied > 0, name);
  }
  // Both versions hold the same grid.
  for (const [name, bytes] of files) {
    const a = parseCgc(bytes);
    const b = parseCgc(toVersion2(bytes));
    assert.deepEqual([b.blocks, b.metacells, b.cells], [a.blocks, a.metacells, a.cells], name);
  }
});

test('every truncation is refused (larger files: at the positions above)', () => {
  for (const [name, bytes] of versions) {
    const v = bytes[8];
    for (const n of positions(bytes)) {
      const m = refused(bytes.subarray(0, n));
      assert.ok(m, `${name} cut to ${n} bytes was accepted`);
      if (n < 320) assert.match(m, /shorter than the 320-byte \.cgc header/);
      else if (v === 2 && n >= HEAD_READ) assert.match(m, /does not fit|truncated/, `${name} at ${n}: ${m}`);
    }
  }
});

test('every single-byte change is refused (larger files: at the positions above; version 1: except the unchecked zero gaps)', () => {
  for (const [name, bytes] of versions) {
    const v1 = bytes[8] === 1;
    const f = parseCgc(bytes);
    const inSection = (i) => i < 320 || f.header.sections.some((s) => i >= s.offset && i < s.offset + s.length);
    for (const i of positions(bytes)) {
      if (v1 && !inSection(i)) continue;
      const b = bytes.slice();
      b[i] ^= 0x5a;
      assert.ok(refused(b), `${name}: byte ${i} changed was accepted`);
    }
  }
});

test('messages name the problem as the Rust reader does', () => {
  const [, bytes] = files[0];
  const damaged = bytes.slice();
  damaged[200] ^= 1;
  assert.equal(refused(damaged), 'header checksum mismatch (the header is damaged)');
  const future = bytes.slice();
  future[8] = 3;
  assert.equal(refused(resealHeader(future)), 'format version 3; this viewer reads versions 1 and 2');
  const notCgc = bytes.slice();
  notCgc[1] = 0x50;
  assert.equal(refused(notCgc), 'not a .cgc file (bad magic bytes)');
  const v2 = toVersion2(bytes);
  const cells = parseCgc(v2).header.cells;
  v2[cells.offset + 3] ^= 1;
  assert.equal(refused(v2), 'cells section checksum mismatch (the data is damaged)');
});

test('version 2: optional unknown sections are skipped (CRC checked), required ones refused', () => {
  const [, bytes] = files[0];
  const extra = new Uint8Array([1, 2, 3, 4, 5]);
  const ok = toVersion2(bytes, [{ kind: 99, flags: 0, bytes: extra }]);
  assert.equal(parseCgc(ok).header.sections.length, 4);
  const bad = ok.slice();
  bad[bad.length - 1] ^= 1;
  assert.equal(refused(bad), 'section 3 (kind 99) section checksum mismatch (the data is damaged)');
  const required = toVersion2(bytes, [{ kind: 99, flags: 1, bytes: extra }]);
  assert.equal(refused(required), 'section 3 (kind 99) is required, and this viewer does not know its kind');
  const twice = toVersion2(bytes, [{ kind: 1, flags: 1, bytes: parseCgc(bytes).blocks }]);
  assert.equal(refused(twice), 'two blocks sections');
});

/** A ByteSource over bytes, counting what was read. */
function memorySource(bytes) {
  const reads = [];
  return {
    name: 'memory.cgc',
    total: bytes.length,
    notice: null,
    reads,
    async read(start, end) {
      reads.push([start, Math.min(end, bytes.length)]);
      return bytes.slice(start, Math.min(end, bytes.length));
    },
  };
}

test('streaming reads each byte once and hands over every cluster with its cells', async () => {
  for (const [name, bytes] of versions) {
    const src = memorySource(bytes);
    let slots = 0;
    let cells = 0;
    let firstClustersAt = null;
    let received = 0;
    const h = await streamCgc(src, {
      header() {},
      clusters(firstSlot, metacells, firstCell, cellBytes, counts) {
        assert.equal(firstSlot, slots);
        assert.equal(firstCell, cells);
        assert.equal(metacells.length, counts.length * 16 * 12);
        slots += counts.length * 16;
        cells += counts.reduce((a, b) => a + b, 0);
        firstClustersAt ??= received;
      },
      progress(r) {
        received = r;
      },
    }, 64);
    assert.equal(slots, h.slotCount, name);
    assert.equal(cells, h.activeCells, name);
    const sorted = [...src.reads].sort((a, b) => a[0] - b[0]);
    let at = 0;
    for (const [s, e] of sorted) {
      assert.equal(s, at, `${name}: bytes ${at}..${s} read twice or never`);
      at = e;
    }
    assert.equal(at, bytes.length);
    if (h.cells.length > 64) assert.ok(firstClustersAt < bytes.length, `${name}: first clusters only after the whole file`);
  }
});

test('streaming refuses damaged and truncated files', async () => {
  for (const [name, bytes] of versions) {
    const sink = { header() {}, clusters() {}, progress() {} };
    const damaged = bytes.slice();
    damaged[bytes.length - 20] ^= 1;
    await assert.rejects(streamCgc(memorySource(damaged), sink, 64), CgcError, name);
    const cut = memorySource(bytes);
    const read = cut.read;
    cut.read = async (s, e) => (await read(s, e)).subarray(0, Math.max(0, Math.min(e, bytes.length - 7) - s));
    await assert.rejects(streamCgc(cut, sink, 64), /truncated/, name);
  }
});

const rules = JSON.parse(readFileSync(new URL('./rules.generated.json', import.meta.url), 'utf8'));

test('attribute codes and the default colour range follow the Rust rules (vectors generated from isogrid::attribute)', () => {
  assert.ok(rules.codes16.length >= 12);
  for (const c of rules.codes16) {
    const n = c.values.length;
    // The section's value bytes as Rust stores them: codes for 8 and 16 bits, f32 values for 32.
    const values = new Uint8Array((n * c.bits) / 8);
    const v = new DataView(values.buffer);
    for (let i = 0; i < n; i++) {
      if (c.bits === 8) values[i] = c.codes[i];
      else if (c.bits === 16) v.setUint16(2 * i, c.codes[i], true);
      else v.setFloat32(4 * i, c.values[i] ?? NaN, true);
    }
    const { codes, mapping } = codes16({ info: { name: c.name, bits: c.bits, range: c.range }, values });
    const what = `${c.name}, ${c.bits} bits`;
    assert.deepEqual([...codes], c.codes, what);
    assert.deepEqual([mapping.zero, mapping.step, mapping.nanCode], [c.zero, c.step, c.nan_code], what);
    // Decoding as color.wgsl's record_value does (in f32 there; here the f64 rule rounded to f32).
    const decoded = [...codes].map((k) => (k === mapping.nanCode ? null : Math.fround(mapping.zero + k * mapping.step)));
    if (c.bits !== 32) assert.deepEqual(decoded, c.values.map((x) => (x === null ? null : Math.fround(x))), what);
  }
  for (const { range, clim } of rules.default_clim) assert.deepEqual(defaultClim(range), clim, JSON.stringify(range));
});

test('directions that mirror the world are told as the Rust rule tells them (vectors generated from directions_mirror)', () => {
  assert.ok(rules.mirrored_axes.length >= 8);
  assert.ok(rules.mirrored_axes.some((c) => c.mirrors) && rules.mirrored_axes.some((c) => !c.mirrors));
  for (const c of rules.mirrored_axes) assert.equal(directionsMirror(c.direction), c.mirrors, JSON.stringify(c));
});

test('an empty surface is explained as the command line explains it (vectors generated from GridInfo::empty_surface_note)', () => {
  assert.ok(rules.empty_notes.length >= 10);
  for (const c of rules.empty_notes) {
    const header = {
      dims: c.dims,
      scalarType: SCALAR_TYPES.indexOf(c.scalar_type),
      valueRange: c.value_range,
      iso: c.iso,
      precisionBits: c.precision_bits,
    };
    assert.equal(emptySurfaceNote(header, c.labels && c.labels.map(BigInt)), c.note, JSON.stringify(c));
  }
});

test('attribute sections of 8, 16 and 32 bits read as isogrid info reports them, and decode within half a code', { skip: !isogridBinary() && 'no isogrid binary' }, () => {
  let prev16 = null;
  for (const bits of [8, 16, 32]) {
    const file = coloredSphereFile(24, bits);
    const f = parseCgc(new Uint8Array(readFileSync(file)));
    const info = infoJson(file).attribute;
    assert.deepEqual([f.attribute.info.bits, f.attribute.info.range, f.attribute.info.name], [info.bits, info.range, info.name]);
    assert.equal(96 + f.attribute.values.length, info.bytes);
    assert.equal(f.attribute.values.length, (f.header.activeCells * bits) / 8);
    // The same surface at every precision: the decoded codes agree within the coarser half step.
    const { codes, mapping } = codes16(f.attribute);
    const values = [...codes].map((k) => mapping.zero + k * mapping.step);
    if (prev16) {
      const [lo, hi] = info.range;
      const tol = (hi - lo) / 254 / 2 + 1e-9 * (hi - lo);
      values.forEach((x, i) => assert.ok(Math.abs(x - prev16[i]) <= tol, `${bits} bits, cell ${i}: ${x} vs ${prev16[i]}`));
    }
    if (bits === 8) prev16 = values;
  }
});

test('label sections read as isogrid info reports them; hiding goes by the index', { skip: !isogridBinary() && 'no isogrid binary' }, () => {
  const file = labelFile();
  const f = parseCgc(new Uint8Array(readFileSync(file)));
  const info = infoJson(file).labels;
  const hex = (rgba) => '#' + rgba.map((c) => c.toString(16).padStart(2, '0')).join('');
  assert.deepEqual(
    f.labels.table.map((l, i) => ({ value: Number(labelText(l.value, f.header.scalarType)), name: l.name, color: hex(l.rgba), cells: f.labels.index[i].cellCount, lo: f.labels.index[i].lo, hi: f.labels.index[i].hi })),
    info.map(({ value, name, color, cells, lo, hi }) => ({ value, name, color, cells, lo, hi })),
  );
  assert.deepEqual(info.map((l) => l.value), [1, 2, 3, 9]);
  // Every cluster's albedo, read as cluster_albedo (color.wgsl) reads the colour words, is its
  // label's colour decoded, and a miss's is zero; hiding a label marks exactly its clusters.
  const words = labelColorWords(f.labels);
  const asFloat = new Float32Array(words.buffer);
  const albedoOf = (cluster) => [0, 1, 2].map((k) => asFloat[words[0] + 4 * words[1 + cluster] + k]);
  assert.equal(words.length, 2 + f.labels.clusterLabels.length + 4 * (f.labels.table.length + 1));
  assert.deepEqual(albedoOf(f.labels.clusterLabels.length), [0, 0, 0]);
  const decoded = (c) => (c / 255 <= 0.04045 ? c / 255 / 12.92 : ((c / 255 + 0.055) / 1.055) ** 2.4);
  const hidden = hiddenClusters(f.labels, [1]);
  f.labels.clusterLabels.forEach((l, c) => {
    assert.equal(hidden[c], l === 1 ? 1 : 0);
    albedoOf(c).forEach((v, k) => assert.ok(Math.abs(v - decoded(f.labels.table[l].rgba[k])) < 1e-3, `cluster ${c}`));
  });
  assert.ok(hidden.some((h) => h) && hidden.some((h) => !h));
});

test('damaged label and attribute sections that pass their checksums are refused with the Rust messages, whole and streamed', { skip: !isogridBinary() && 'no isogrid binary' }, async () => {
  const labels = new Uint8Array(readFileSync(labelFile()));
  const h = parseCgc(labels).header;
  const entry = (kind) => h.sections.findIndex((s) => s.kind === kind);
  const edit = (bytes, kind, change) => {
    const b = bytes.slice();
    const s = h.sections[entry(kind)];
    change(new DataView(b.buffer, s.offset, s.length), b.subarray(s.offset, s.offset + s.length));
    return resealSection(b, entry(kind));
  };
  const cases = [
    [edit(labels, 5, (v) => v.setUint32(0, 4, true)), 'cluster 0 has label 4 of 4'],
    [edit(labels, 5, (v) => v.setUint32(0, v.getUint32(0, true) === 0 ? 1 : 0, true)), /^label index entry \d: cluster \d+ in its runs has another label$/],
    [edit(labels, 6, (v) => v.setBigUint64(16, v.getBigUint64(16, true) + 1n, true)), 'label index entry 0: its cell count or bounds do not match its clusters'],
    [edit(labels, 6, (v) => v.setUint32(16 + 24, v.getUint32(16 + 24, true) + 1, true)), 'label index entry 0: its cell count or bounds do not match its clusters'],
    [edit(labels, 6, (v) => v.setBigUint64(8, 1n << 61n, true)), /^label index section is \d+ bytes, not the head, 4 entries and 2305843009213693952 runs$/],
    [edit(labels, 7, (v) => v.setBigUint64(32, 1n, true)), 'label table entry 1: values are not strictly increasing'],
    [edit(labels, 7, (v) => v.setBigUint64(0, 1n << 60n, true)), /^label table section is \d+ bytes, not the head, 1152921504606846976 entries/],
    [edit(labels, 7, (v) => v.setUint32(16 + 12, 200, true)), 'label table entry 0: its name runs past the names'],
    [edit(labels, 7, (v, b) => (b[b.length - 1] = 0xff)), 'label table entry 3: name is not UTF-8'],
  ];
  // A label section of a kind this reader does not know leaves the other two alone.
  const unknown = labels.slice();
  new DataView(unknown.buffer).setUint32(320 + 32 * entry(6), 99, true);
  const uv = new DataView(unknown.buffer);
  uv.setUint32(172, 0, true);
  cases.push([resealSection(unknown, entry(6)), 'the file has some of the three label sections but not all']);
  const colored = new Uint8Array(readFileSync(coloredSphereFile(24, 32)));
  const ch = parseCgc(colored).header;
  const at = ch.sections.findIndex((s) => s.kind === 4);
  const editAttr = (change) => {
    const b = colored.slice();
    change(new DataView(b.buffer, ch.attribute.offset, ch.attribute.length));
    return resealSection(b, at);
  };
  cases.push(
    [editAttr((v) => v.setFloat32(96, 1e9, true)), /^cell attribute value 1000000000 lies outside its range \[/],
    [editAttr((v) => v.setUint32(4, 12, true)), 'cell attribute of 12 bits per value'],
    [editAttr((v) => v.setBigUint64(24, 7n, true)), /^cell attribute section holds \d+ bytes of values, and 7 values for \d+ active cells$/],
    [editAttr((v) => v.setFloat64(8, NaN, true)), /^cell attribute range \[NaN, .*\] is not finite and ordered$/],
    [editAttr((v) => v.setUint8(95, 1)), 'cell attribute name is not zero-padded'],
  );
  for (const [bytes, expected] of cases) {
    const m = refused(bytes);
    if (expected instanceof RegExp) assert.match(m ?? 'accepted', expected);
    else assert.equal(m, expected);
    // Streamed into a sink that takes only the cells, as the viewer's takes no whole attribute.
    let streamed = 'accepted';
    await streamCgc(memorySource(bytes), { header() {}, progress() {}, clusters() {} }).catch((e) => (streamed = e.message));
    if (expected instanceof RegExp) assert.match(streamed, expected);
    else assert.equal(streamed, expected);
  }
});

test('the world frame section reads as isogrid info reports it, whole and streamed; a damaged one is refused with the Rust message', { skip: !isogridBinary() && 'no isogrid binary' }, async () => {
  const file = placedSphereFile();
  const bytes = new Uint8Array(readFileSync(file));
  const info = infoJson(file).source;
  const { header, frame } = parseCgc(bytes);
  assert.equal(frame, info.frame);
  assert.deepEqual(header.direction, info.direction);
  assert.deepEqual(header.origin, info.origin);
  let streamed = null;
  await streamCgc(memorySource(bytes), { header() {}, progress() {}, clusters() {}, worldFrame: (f) => (streamed = f) });
  assert.equal(streamed, 'RAS');
  // Without the section the frame is unknown.
  assert.equal(parseCgc(new Uint8Array(readFileSync(coloredSphereFile(24, 16)))).frame, null);
  const at = header.sections.findIndex((s) => s.kind === 8);
  for (const change of [(b) => (b[0] = 3), (b) => (b[0] = 0), (b) => (b[7] = 1)]) {
    const b = bytes.slice();
    change(b.subarray(header.worldFrame.offset, header.worldFrame.offset + 8));
    const damaged = resealSection(b, at);
    assert.equal(refused(damaged), 'world frame section is not an LPS (1) or RAS (2) code');
    await assert.rejects(streamCgc(memorySource(damaged), { header() {}, progress() {}, clusters() {} }), (e) => e instanceof CgcError && e.message === 'world frame section is not an LPS (1) or RAS (2) code');
  }
});

test('streaming hands over the attribute with the cells it colours, and the labels before the first clusters', async () => {
  for (const [name, bytes] of versions.filter(([n]) => /colored|labels/.test(n))) {
    const src = memorySource(bytes);
    const got = { values: [] };
    let received = 0;
    let valuesIn = 0;
    let cellsOut = 0;
    let firstClustersAt = null;
    await streamCgc(src, {
      header() {},
      clusters(firstSlot, metacells, firstCell, cells, counts) {
        cellsOut = firstCell + counts.reduce((a, b) => a + b, 0);
        if (got.head) assert.ok(valuesIn >= cellsOut, `${name}: cells up to ${cellsOut} handed over with values up to ${valuesIn}`);
        firstClustersAt ??= received;
      },
      progress(r) {
        received = r;
      },
      attributeHead(info) {
        got.head = info;
      },
      attributeValues(first, values) {
        assert.equal(first, valuesIn);
        valuesIn += values.length / (got.head.bits / 8);
        got.values.push(values.slice());
      },
      attribute(a) {
        got.attribute = a;
      },
      labels(l) {
        got.labels = l;
        got.labelsAt = received;
      },
    }, 256);
    const whole = parseCgc(bytes);
    assert.deepEqual(got.attribute ?? null, whole.attribute, name);
    assert.deepEqual(got.labels ?? null, whole.labels, name);
    if (whole.attribute) {
      assert.deepEqual(got.head, whole.attribute.info);
      assert.deepEqual(Buffer.concat(got.values), Buffer.from(whole.attribute.values), name);
    }
    assert.ok(firstClustersAt < bytes.length, `${name}: first clusters after ${firstClustersAt} of ${bytes.length} bytes`);
    // Label colours before the first clusters are drawn.
    if (whole.labels) assert.ok(got.labelsAt <= firstClustersAt, `${name}: labels after ${got.labelsAt} bytes, clusters after ${firstClustersAt}`);
  }
});

test('streaming checks the labels against the metacells after handing them over', { skip: !isogridBinary() && 'no isogrid binary' }, async () => {
  const bytes = new Uint8Array(readFileSync(labelFile()));
  const sections = parseCgc(bytes).header.sections;
  const entry = sections.findIndex((s) => s.kind === 6);
  const b = bytes.slice();
  const v = new DataView(b.buffer, sections[entry].offset);
  v.setBigUint64(16, v.getBigUint64(16, true) + 1n, true); // label 0's cell count
  resealSection(b, entry);
  const sink = { header() {}, clusters() {}, progress() {}, labels() {} };
  await assert.rejects(streamCgc(memorySource(b), sink, 256), /^CgcError: label index entry 0: its cell count or bounds do not match its clusters$/);
});

test('back-face culling is allowed exactly when no border sample is inside (BorderCheck, streamed)', async (t) => {
  if (!isogridBinary()) {
    t.skip('no isogrid binary built: no volume to extract');
    return;
  }
  const n = 40;
  // A ball well inside, one cut by the x = 0 face, and one touching the far corner region.
  for (const [cx, r] of [[20, 10], [3, 12], [36, 9]]) {
    const { cgc, value } = ballFile(n, cx, r);
    // Brute force over the volume's border samples: is any inside (value ≥ isovalue)?
    let inside = false;
    for (let z = 0; z < n; z++) for (let y = 0; y < n; y++) for (let x = 0; x < n; x++) {
      const border = [x, y, z].some((v) => v === 0 || v === n - 1);
      if (border && value(x, y, z) >= 100) inside = true;
    }
    const told = [];
    await streamCgc(memorySource(new Uint8Array(readFileSync(cgc))), { header() {}, clusters() {}, progress() {}, borderOutside: (o) => told.push(o) }, 4096);
    assert.ok(told.length >= 1, 'told once the blocks are in');
    assert.equal(told.at(-1), !inside, `ball at x = ${cx}, radius ${r}: ${told}`);
    // It only ever turns false as clusters arrive.
    assert.ok(told.every((o, i) => i === 0 || (told[i - 1] && !o)), `${told}`);
  }
});

test('a metacell whose mask reaches past the grid\'s last cell is refused with the Rust message', (t) => {
  if (!isogridBinary()) {
    t.skip('no isogrid binary built: no volume to extract');
    return;
  }
  // 34 samples, 33 cells a side: the last block's metacell 16 holds cell 32 on its low side and
  // the non-cell 33 on its high side. A ball through the x = 33 face gives cells at x = 32.
  const { cgc } = ballFile(34, 33, 8);
  const bytes = new Uint8Array(readFileSync(cgc));
  const h = parseCgc(bytes).header;
  const entry = h.sections.indexOf(h.metacells);
  const m = new DataView(bytes.buffer, bytes.byteOffset + h.metacells.offset, h.metacells.length);
  let tried = 0;
  for (let slot = 0; slot < h.metacells.length / 12; slot++) {
    const mask = m.getUint16(12 * slot + 6, true);
    if (slot % 16 === 15 || mask === 0 || m.getUint16(12 * slot, true) !== 16) continue;
    // Each x-low cell of the mask given its x-high neighbour, cell 33: past the grid.
    const withHigh = mask | ((mask & 0x55) << 1);
    if (withHigh === mask) continue;
    const b = bytes.slice();
    new DataView(b.buffer, b.byteOffset + h.metacells.offset).setUint16(12 * slot + 6, withHigh, true);
    assert.equal(refused(resealSection(b, entry)), `metacell slot ${slot}: active cell outside the grid`);
    tried++;
  }
  assert.ok(tried >= 3, `${tried} metacells at x = 32 changed`);
});

test('CRC-32 of every length and any split into updates is zlib\'s', () => {
  const bytes = new Uint8Array(randomBytes(4099));
  for (let n = 0; n <= 64; n++) assert.equal(crc32(bytes.subarray(0, n)), zlib.crc32(bytes.subarray(0, n)), `length ${n}`);
  assert.equal(crc32(bytes), zlib.crc32(bytes));
  for (let trial = 0; trial < 50; trial++) {
    // Updates of random lengths, so that the eight-byte steps start at any offset.
    const c = new Crc32();
    for (let at = 0; at < bytes.length; ) {
      const end = Math.min(bytes.length, at + Math.floor(Math.random() * 37));
      c.update(bytes.subarray(at, end));
      at = end;
    }
    assert.equal(c.digest(), zlib.crc32(bytes), `trial ${trial}`);
  }
});
