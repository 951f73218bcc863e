// The packed transfer form (.cgcz, written by `isogrid pack`) rebuilt by web/src/packed.ts: byte for
// byte the .cgc the binary writes, at every corner precision, with and without a cell attribute,
// label grids binary and smoothed, a grid with a world frame,
// whether the bytes arrive at once or a few at a time; and every truncation and single-byte change
// of a packed file refused with a CgcError (by the packed head, the inflater, the range decoder, the rebuild or the
// .cgc's own checks on the rebuilt bytes) or rebuilt into the same file, never a different one.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { CgcError, parseCgc } from '../build/node/cgc.js';
import { packedSource } from '../build/node/packed.js';
import { isogridBinary, sphereFile, coloredSphereFile, precisionSphereFile, packedFile, labelFile, placedSphereFile, streamOf } from './fixtures.mjs';

const bin = isogridBinary();
// Browsers have it; node has it since 20.14 and 21.2 (Debian bookworm's node 18 does not).
const inflates = (() => {
  try {
    new DecompressionStream('deflate-raw');
    return true;
  } catch {
    return false;
  }
})();
const skip = !bin
  ? 'no isogrid binary built (cargo build -p isogrid-cli)'
  : !inflates && `node ${process.version} has no DecompressionStream('deflate-raw') (node >= 20.14)`;

/** The .cgc that `packed` rebuilds, and the packed bytes counted on the way. */
async function rebuild(packed, piece) {
  let counted = 0;
  const src = packedSource('test.cgcz', async () => streamOf(packed, piece), (n) => (counted += n));
  const head = await src.read(0, 320);
  const file = await src.read(0, src.total);
  return { head, file, counted };
}

/** The outcome of rebuilding damaged bytes: 'refused', 'same' (rebuilt the original) or a failure. */
async function outcome(packed, original) {
  let file;
  try {
    ({ file } = await rebuild(packed));
  } catch (e) {
    if (e instanceof CgcError) return 'refused';
    return `threw ${e}`;
  }
  if (Buffer.compare(Buffer.from(file), Buffer.from(original)) === 0) return 'same';
  try {
    parseCgc(file);
  } catch (e) {
    if (e instanceof CgcError) return 'refused';
    return `threw ${e}`;
  }
  return 'a different valid file';
}

const cases = !skip
  ? [
      ['sphere48.cgc', sphereFile()],
      ...[1, 4, 8, 16, 32].map((bits) => [`sphere24 at ${bits}-bit corners`, precisionSphereFile(bits)]),
      ...[8, 16, 32].map((bits) => [`sphere24 with a ${bits}-bit attribute`, coloredSphereFile(24, bits)]),
      ['labels32.cgc', labelFile(32)],
      ['labels32.cgc smoothed (sigma 1)', labelFile(32, 1)],
      ['placed24.cgc, with a world frame', placedSphereFile()],
    ]
  : [];

test('a packed file rebuilds its .cgc byte for byte', { skip }, async (t) => {
  for (const [name, cgc] of cases) {
    const original = new Uint8Array(readFileSync(cgc));
    const packed = new Uint8Array(readFileSync(packedFile(cgc)));
    for (const piece of [packed.length, 7]) {
      const { file, counted } = await rebuild(packed, piece);
      assert.equal(counted, packed.length, name);
      assert.ok(Buffer.compare(Buffer.from(file), Buffer.from(original)) === 0, `${name}: the rebuilt file differs (pieces of ${piece})`);
    }
    t.diagnostic(`${name}: ${original.length} bytes packed into ${packed.length} (${(original.length / packed.length).toFixed(2)}×)`);
  }
});

test('a packed file of another version is refused by its version', { skip }, async () => {
  const packed = new Uint8Array(readFileSync(packedFile(precisionSphereFile(8))));
  for (const version of [1, 3]) {
    const b = packed.slice();
    new DataView(b.buffer).setUint32(8, version, true);
    const src = packedSource('old.cgcz', async () => streamOf(b), () => {});
    await assert.rejects(src.read(0, 320), (e) => e instanceof CgcError && e.unsupported && e.message === `packed format version ${version}; this viewer reads version 2 (pack the .cgc again with this isogrid)`);
  }
});

test('every truncation and single-byte change of a packed file is refused', { skip, timeout: 600_000 }, async (t) => {
  for (const cgc of !skip ? [precisionSphereFile(8), labelFile(32), placedSphereFile()] : []) {
    const original = new Uint8Array(readFileSync(cgc));
    const packed = new Uint8Array(readFileSync(packedFile(cgc)));
    for (let n = 0; n < packed.length; n++) {
      assert.equal(await outcome(packed.subarray(0, n), original), 'refused', `${cgc}: cut to ${n} of ${packed.length} bytes`);
    }
    const appended = new Uint8Array(packed.length + 1);
    appended.set(packed);
    assert.equal(await outcome(appended, original), 'refused', `${cgc}: a byte appended`);
    const same = [];
    for (let i = 0; i < packed.length; i++) {
      for (const flip of [0x01, 0x80]) {
        const b = packed.slice();
        b[i] ^= flip;
        // A few bits change nothing that is read back: the range coder's flush at the end of the
        // block stream carries more precision than its last symbols need, and a deflate stream has
        // bits that do not change what it inflates to (padding, code lengths of symbols it never
        // uses). Rebuilding the same file is no harm, and the file's checksums hold it to be that
        // file.
        const got = await outcome(b, original);
        assert.ok(got === 'refused' || got === 'same', `${cgc}: byte ${i} ^ ${flip}: ${got}`);
        if (got === 'same') same.push(`${i}^${flip}`);
      }
    }
    t.diagnostic(`${cgc}: ${packed.length} bytes, ${2 * packed.length} changes: ${same.length} rebuilt the same file (${same.join(', ')}), the rest refused`);
  }
});

test('runs of random bytes in a packed file are refused, never a different file or a hang', { skip, timeout: 600_000 }, async (t) => {
  // Single-byte changes leave the coder's state near a valid one; runs of garbage drive the range
  // decoder, the models and the rebuild's checks far from any stream the packer writes.
  let seed = 12345;
  const random = () => ((seed = (Math.imul(seed, 1103515245) + 12345) >>> 0) / 2 ** 32);
  for (const cgc of !skip ? [precisionSphereFile(16), coloredSphereFile(24, 16), labelFile(32, 1)] : []) {
    const original = new Uint8Array(readFileSync(cgc));
    const packed = new Uint8Array(readFileSync(packedFile(cgc)));
    const tally = { refused: 0, same: 0 };
    for (let trial = 0; trial < 300; trial++) {
      const b = packed.slice();
      const length = 1 + Math.floor(random() * 64);
      const at = Math.floor(random() * (b.length - length));
      for (let i = at; i < at + length; i++) b[i] = Math.floor(random() * 256);
      const got = await outcome(b, original);
      assert.ok(got === 'refused' || got === 'same', `${cgc}: ${length} random bytes at ${at}: ${got}`);
      tally[got]++;
    }
    t.diagnostic(`${cgc}: 300 runs of random bytes: ${tally.refused} refused, ${tally.same} rebuilt the same file`);
  }
});
