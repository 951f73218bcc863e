// .cgc files for the tests: written by the `isogrid` binary where one is built (a sphere of 48³
// samples, version as that binary writes), the repository's fixtures, and version 2 files made
// from version 1 ones by `toVersion2` (the layout of the format spec in docs/design/web.md), so
// that both versions are covered whichever the binary writes.
import { existsSync, mkdirSync, readFileSync, readdirSync, statSync, writeFileSync } from 'node:fs';
import { createHash } from 'node:crypto';
import { execFileSync, spawnSync } from 'node:child_process';
import { basename, join, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';
import { tmpdir } from 'node:os';
import { crc32 } from '../build/node/crc32.js';

export const repo = join(dirname(fileURLToPath(import.meta.url)), '..', '..');

/** The isogrid binary: $ISOGRID_BIN, or target/debug or target/release of this checkout. */
export function isogridBinary() {
  const candidates = [process.env.ISOGRID_BIN, join(repo, 'target', 'debug', 'isogrid'), join(repo, 'target', 'release', 'isogrid')];
  return candidates.find((c) => c && existsSync(c)) ?? null;
}

/** A sphere .cgc (and its volume) written by the binary into a temporary folder, or null. */
export function sphereFile(size = 48) {
  const bin = isogridBinary();
  if (!bin) return null;
  const dir = binaryDir(bin);
  const cgc = join(dir, `sphere${size}.cgc`);
  if (!existsSync(cgc)) {
    execFileSync(bin, ['generate', 'sphere', '--size', String(size), '-o', join(dir, `sphere${size}.nrrd`)], { stdio: 'ignore' });
    execFileSync(bin, ['extract', join(dir, `sphere${size}.nrrd`), '--iso-normalized', '0.5', '-o', cgc], { stdio: 'ignore' });
  }
  return cgc;
}

/** A folder for files the binary writes, one per binary build (a rebuilt binary writes afresh). */
function binaryDir(bin) {
  const key = createHash('sha1').update(`${bin} ${statSync(bin).mtimeMs}`).digest('hex').slice(0, 12);
  const dir = join(tmpdir(), `isogrid-web-test-${key}`);
  mkdirSync(dir, { recursive: true });
  return dir;
}

/**
 * The sphere coloured by a gyroid (`extract --color-by`: a cell attribute section of `bits` bits
 * per value), or null.
 */
export function coloredSphereFile(size = 32, bits = 16) {
  const bin = isogridBinary();
  if (!bin) return null;
  const dir = binaryDir(bin);
  const cgc = join(dir, bits === 16 ? `colored${size}.cgc` : `colored${size}-${bits}.cgc`);
  if (!existsSync(cgc)) {
    for (const field of ['sphere', 'gyroid']) {
      execFileSync(bin, ['generate', field, '--size', String(size), '-o', join(dir, `${field}${size}.nrrd`)], { stdio: 'ignore' });
    }
    execFileSync(bin, ['extract', join(dir, `sphere${size}.nrrd`), '--iso-normalized', '0.5',
      '--color-by', join(dir, `gyroid${size}.nrrd`), '--attribute-precision', String(bits), '-o', cgc], { stdio: 'ignore' });
  }
  return cgc;
}

/**
 * The label value of sample (x, y, z) of the test's label volume of n³ samples: two balls that
 * touch (labels 1 and 2), a box cut into the first (3), and a small ball apart (label 9).
 */
export function labelAt(x, y, z, n) {
  const s = n / 32;
  const ball = (cx, cy, cz, r) => (x - cx * s) ** 2 + (y - cy * s) ** 2 + (z - cz * s) ** 2 < (r * s) ** 2;
  if (x >= 4 * s && x < 13 * s && y >= 18 * s && y < 28 * s && z >= 8 * s && z < 24 * s) return 3;
  if (ball(11, 13, 15, 8)) return 1;
  if (ball(21, 14, 16, 7)) return 2;
  if (ball(24, 25, 10, 4)) return 9;
  return 0;
}

/** A .npy of u8 samples, x fastest (shape (z, y, x) in C order, as isogrid reads .npy). */
function writeNpy(path, n, value) {
  const data = new Uint8Array(n * n * n);
  for (let z = 0; z < n; z++) for (let y = 0; y < n; y++) for (let x = 0; x < n; x++) data[(z * n + y) * n + x] = value(x, y, z, n);
  let header = `{'descr': '|u1', 'fortran_order': False, 'shape': (${n}, ${n}, ${n}), }`;
  header += ' '.repeat(63 - ((10 + header.length) % 64)) + '\n';
  const head = Buffer.alloc(10);
  head.write('\x93NUMPY', 0, 'latin1');
  head[6] = 1;
  head.writeUInt16LE(header.length, 8);
  writeFileSync(path, Buffer.concat([head, Buffer.from(header, 'latin1'), Buffer.from(data)]));
}

/**
 * The label grid of `labelAt` (`extract --labels all`: the three label sections; with `smooth`,
 * `--smooth SIGMA`), or null.
 */
export function labelFile(n = 32, smooth = null) {
  const bin = isogridBinary();
  if (!bin) return null;
  const dir = binaryDir(bin);
  const cgc = join(dir, smooth === null ? `labels${n}.cgc` : `labels${n}-smooth${smooth}.cgc`);
  if (!existsSync(cgc)) {
    writeNpy(join(dir, `labels${n}.npy`), n, labelAt);
    const smoothing = smooth === null ? [] : ['--smooth', String(smooth)];
    execFileSync(bin, ['extract', join(dir, `labels${n}.npy`), '--labels', 'all', ...smoothing, '-o', cgc], { stdio: 'ignore' });
  }
  return cgc;
}

/**
 * The label grid of `labelAt` coloured by a gyroid of the same grid (`extract --labels all
 * --color-by`: the attribute section beside the three label sections), or null.
 */
export function colouredLabelFile(n = 48) {
  const bin = isogridBinary();
  if (!bin) return null;
  const dir = binaryDir(bin);
  const cgc = join(dir, `colored-labels${n}.cgc`);
  if (!existsSync(cgc)) {
    writeNpy(join(dir, `labels${n}.npy`), n, labelAt);
    execFileSync(bin, ['generate', 'gyroid', '--size', String(n), '-o', join(dir, `gyroid${n}.nrrd`)], { stdio: 'ignore' });
    execFileSync(bin, ['extract', join(dir, `labels${n}.npy`), '--labels', 'all',
      '--color-by', join(dir, `gyroid${n}.nrrd`), '-o', cgc], { stdio: 'ignore' });
  }
  return cgc;
}

/**
 * Grids without a surface, written by the binary (the sphere extracted above every sample, an 8³
 * volume that label 7 fills), each with the note `isogrid info` prints for it, past its
 * `isogrid: note: PATH: `: [name, path, note]; none without the binary.
 */
export function emptyFiles() {
  const bin = isogridBinary();
  if (!bin) return [];
  const dir = binaryDir(bin);
  sphereFile(48);
  const iso = join(dir, 'empty-iso.cgc');
  const labels = join(dir, 'empty-labels.cgc');
  if (!existsSync(iso)) execFileSync(bin, ['extract', join(dir, 'sphere48.nrrd'), '--iso', '1000', '-o', iso], { stdio: 'ignore' });
  if (!existsSync(labels)) {
    writeNpy(join(dir, 'filled8.npy'), 8, () => 7);
    execFileSync(bin, ['extract', join(dir, 'filled8.npy'), '--labels', 'all', '-o', labels], { stdio: 'ignore' });
  }
  return [iso, labels].map((path) => [basename(path), path, infoNote(path)]);
}

/** The note `isogrid info` prints for `path`, past its `isogrid: note: PATH: `. */
export function infoNote(path) {
  const { stderr } = spawnSync(isogridBinary(), ['info', path], { encoding: 'utf8' });
  const prefix = `isogrid: note: ${path}: `;
  const note = stderr.split('\n').find((line) => line.startsWith(prefix));
  if (!note) throw new Error(`isogrid info ${path} printed no note: ${stderr}`);
  return note.slice(prefix.length);
}

/**
 * A ball of value 200 in 0 (u8, n³ samples, centre (cx, n/2, n/2), radius r) extracted at isovalue
 * 100, and the value of sample (x, y, z); null without the binary.
 */
export function ballFile(n, cx, r) {
  const bin = isogridBinary();
  if (!bin) return null;
  const dir = binaryDir(bin);
  const value = (x, y, z) => ((x - cx) ** 2 + (y - n / 2) ** 2 + (z - n / 2) ** 2 < r * r ? 200 : 0);
  const cgc = join(dir, `ball${n}-${cx}-${r}.cgc`);
  if (!existsSync(cgc)) {
    writeNpy(join(dir, `ball${n}-${cx}-${r}.npy`), n, value);
    execFileSync(bin, ['extract', join(dir, `ball${n}-${cx}-${r}.npy`), '--iso', '100', '-o', cgc], { stdio: 'ignore' });
  }
  return { cgc, value };
}

/** The sphere of `sphereFile()` extracted at `bits` bits per corner (1, 4, 8, 16, 32), or null. */
export function precisionSphereFile(bits, size = 24) {
  const bin = isogridBinary();
  if (!bin) return null;
  const dir = binaryDir(bin);
  const cgc = join(dir, `sphere${size}-p${bits}.cgc`);
  if (!existsSync(cgc)) {
    execFileSync(bin, ['generate', 'sphere', '--size', String(size), '-o', join(dir, `sphere${size}.nrrd`)], { stdio: 'ignore' });
    execFileSync(bin, ['extract', join(dir, `sphere${size}.nrrd`), '--iso-normalized', '0.5', '--precision', String(bits), '-o', cgc], { stdio: 'ignore' });
  }
  return cgc;
}

/**
 * A ball with a bump towards the first axis's high end, in patient space: an n³ u8 NRRD in RAS
 * whose first axis runs to the left (axes LAS, a mirror image of RAS), extracted by the binary, so
 * the .cgc has a world frame section; or null. With `twin`, the same world stored the other way
 * round: the samples flipped along the first axis, which then runs to the right (axes RAS).
 */
export function placedSphereFile(n = 24, twin = false) {
  const bin = isogridBinary();
  if (!bin) return null;
  const dir = binaryDir(bin);
  const name = `placed${n}${twin ? '-ras' : ''}`;
  const cgc = join(dir, `${name}.cgc`);
  if (!existsSync(cgc)) {
    const samples = new Uint8Array(n * n * n);
    const c = (n - 1) / 2;
    for (let z = 0; z < n; z++) {
      for (let y = 0; y < n; y++) {
        for (let x = 0; x < n; x++) {
          const ball = Math.hypot(x - c, y - c, z - c) < 0.3 * n;
          const bump = Math.hypot(x - 0.8 * n, y - 0.6 * n, z - c) < 0.12 * n;
          samples[(twin ? n - 1 - x : x) + n * (y + n * z)] = ball || bump ? 200 : 0;
        }
      }
    }
    const header = [
      'NRRD0004', 'type: uint8', 'dimension: 3', `sizes: ${n} ${n} ${n}`, 'space: right-anterior-superior',
      `space directions: (${twin ? 1 : -1},0,0) (0,1,0) (0,0,1)`, `space origin: (${twin ? 10 - (n - 1) : 10},-20,30)`, 'encoding: raw', '', '',
    ].join('\n');
    const nrrd = join(dir, `${name}.nrrd`);
    writeFileSync(nrrd, Buffer.concat([Buffer.from(header), Buffer.from(samples)]));
    execFileSync(bin, ['extract', nrrd, '--iso', '100', '-o', cgc], { stdio: 'ignore' });
  }
  return cgc;
}

/** The packed form (`isogrid pack`, .cgcz) of the .cgc at `cgc`, beside it. */
export function packedFile(cgc) {
  const out = `${cgc}z`;
  if (!existsSync(out)) execFileSync(isogridBinary(), ['pack', cgc, '-o', out], { stdio: 'ignore' });
  return out;
}

/** `isogrid info --json` of `file`. */
export function infoJson(file) {
  return JSON.parse(execFileSync(isogridBinary(), ['info', file, '--json'], { encoding: 'utf8' }));
}

/**
 * Every .cgc in the repository's fixtures and, with the binary, the sphere, spheres with a cell
 * attribute of 8, 16 and 32 bits, a label grid and a ball with a world frame: [name, bytes].
 */
export function realFiles() {
  const dir = join(repo, 'crates', 'isogrid', 'tests', 'fixtures');
  const files = readdirSync(dir).filter((f) => f.endsWith('.cgc')).map((f) => [f, new Uint8Array(readFileSync(join(dir, f)))]);
  const sphere = sphereFile();
  if (sphere) files.push(['sphere48.cgc', new Uint8Array(readFileSync(sphere))]);
  if (isogridBinary()) {
    for (const bits of [8, 16, 32]) files.push([`colored24-${bits}.cgc`, new Uint8Array(readFileSync(coloredSphereFile(24, bits)))]);
    files.push(['labels32.cgc', new Uint8Array(readFileSync(labelFile()))]);
    files.push(['placed24.cgc', new Uint8Array(readFileSync(placedSphereFile()))]);
  }
  return files;
}

const u32 = (b, o) => new DataView(b.buffer, b.byteOffset).getUint32(o, true);
const u64 = (b, o) => Number(new DataView(b.buffer, b.byteOffset).getBigUint64(o, true));

/** Sets the header CRC (bytes 316..320) of `b` after an edit of its header. */
export function resealHeader(b) {
  new DataView(b.buffer, b.byteOffset).setUint32(316, crc32(b.subarray(0, 316)), true);
  return b;
}

/**
 * The version 2 file of the version 1 file `v1`: the same header fields, a section table at 320
 * (`extra`: more entries {kind, flags, bytes} after the grid's three), sections 16-aligned.
 */
export function toVersion2(v1, extra = []) {
  if (u32(v1, 8) !== 1) return v1;
  const sections = [0, 1, 2].map((s) => ({
    kind: s + 1,
    flags: 1,
    bytes: v1.subarray(u64(v1, 160 + 16 * s), u64(v1, 160 + 16 * s) + u64(v1, 168 + 16 * s)),
  }));
  const all = [...sections, ...extra];
  const align = (n) => Math.ceil(n / 16) * 16;
  let at = 320 + 32 * all.length;
  const placed = all.map((s) => {
    const offset = align(at);
    at = offset + s.bytes.length;
    return { ...s, offset };
  });
  const out = new Uint8Array(at);
  out.set(v1.subarray(0, 320));
  const v = new DataView(out.buffer);
  v.setUint32(8, 2, true);
  out.fill(0, 160, 208);
  out.fill(0, 280, 316);
  placed.forEach((s, i) => {
    const e = 320 + 32 * i;
    v.setUint32(e, s.kind, true);
    v.setUint32(e + 4, s.flags, true);
    v.setBigUint64(e + 8, BigInt(s.offset), true);
    v.setBigUint64(e + 16, BigInt(s.bytes.length), true);
    v.setUint32(e + 24, crc32(s.bytes), true);
    out.set(s.bytes, s.offset);
  });
  v.setBigUint64(160, 320n, true);
  v.setUint32(168, all.length, true);
  v.setUint32(172, crc32(out.subarray(320, 320 + 32 * all.length)), true);
  return resealHeader(out);
}

/**
 * Sets the CRC of section table entry `entry` of version 2 file `b` to its bytes' CRC, then the
 * table's and the header's: an edited section that passes every checksum, so the reader's
 * structural checks are what must refuse it.
 */
export function resealSection(b, entry) {
  const v = new DataView(b.buffer, b.byteOffset);
  const e = 320 + 32 * entry;
  const offset = Number(v.getBigUint64(e + 8, true));
  const length = Number(v.getBigUint64(e + 16, true));
  v.setUint32(e + 24, crc32(b.subarray(offset, offset + length)), true);
  v.setUint32(172, crc32(b.subarray(320, 320 + 32 * v.getUint32(168, true))), true);
  return resealHeader(b);
}

/** A stream of `bytes` in pieces of `piece` bytes (a slow link), or in one. */
export function streamOf(bytes, piece = bytes.length) {
  let at = 0;
  return new ReadableStream({
    pull(c) {
      if (at >= bytes.length) return c.close();
      c.enqueue(bytes.slice(at, at + piece));
      at += piece;
    },
  });
}
