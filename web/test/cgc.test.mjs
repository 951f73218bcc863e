// The TypeScript reader (web/src/cgc.ts, loader.ts) against real files: those written by the
// isogrid binary (the repository's fixtures, a sphere when the binary is built) and their version 2
// forms. Every truncation and every single-byte change must be refused, with the Rust reader's
// messages for the cases the page shows.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { parseCgc, CgcError, HEAD_READ } from '../build/node/cgc.js';
import { streamCgc } from '../build/node/loader.js';
import { realFiles, toVersion2, resealHeader, isogridBinary } from './fixtures.mjs';

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
