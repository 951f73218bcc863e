// .cgc files for the tests: written by the `isogrid` binary where one is built (a sphere of 48³
// samples, version as that binary writes), the repository's fixtures, and version 2 files made
// from version 1 ones by `toVersion2` (the layout of the format spec in docs/design/web.md), so
// that both versions are covered whichever the binary writes.
import { existsSync, mkdirSync, readFileSync, readdirSync, statSync } from 'node:fs';
import { createHash } from 'node:crypto';
import { execFileSync } from 'node:child_process';
import { join, dirname } from 'node:path';
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
  // One folder per binary build, so a rebuilt binary (another format version) writes afresh.
  const key = createHash('sha1').update(`${bin} ${statSync(bin).mtimeMs}`).digest('hex').slice(0, 12);
  const dir = join(tmpdir(), `isogrid-web-test-${key}`);
  mkdirSync(dir, { recursive: true });
  const cgc = join(dir, `sphere${size}.cgc`);
  if (!existsSync(cgc)) {
    execFileSync(bin, ['generate', 'sphere', '--size', String(size), '-o', join(dir, `sphere${size}.nrrd`)], { stdio: 'ignore' });
    execFileSync(bin, ['extract', join(dir, `sphere${size}.nrrd`), '--iso-normalized', '0.5', '-o', cgc], { stdio: 'ignore' });
  }
  return cgc;
}

/** The sphere coloured by a gyroid (`extract --color-by`: a cell attribute section), or null. */
export function coloredSphereFile(size = 32) {
  const bin = isogridBinary();
  if (!bin) return null;
  const key = createHash('sha1').update(`${bin} ${statSync(bin).mtimeMs}`).digest('hex').slice(0, 12);
  const dir = join(tmpdir(), `isogrid-web-test-${key}`);
  mkdirSync(dir, { recursive: true });
  const cgc = join(dir, `colored${size}.cgc`);
  if (!existsSync(cgc)) {
    for (const field of ['sphere', 'gyroid']) {
      execFileSync(bin, ['generate', field, '--size', String(size), '-o', join(dir, `${field}${size}.nrrd`)], { stdio: 'ignore' });
    }
    execFileSync(bin, ['extract', join(dir, `sphere${size}.nrrd`), '--iso-normalized', '0.5',
      '--color-by', join(dir, `gyroid${size}.nrrd`), '-o', cgc], { stdio: 'ignore' });
  }
  return cgc;
}

/**
 * Every .cgc in the repository's fixtures and, with the binary, the sphere and a sphere with a
 * cell attribute: [name, bytes].
 */
export function realFiles() {
  const dir = join(repo, 'crates', 'isogrid', 'tests', 'fixtures');
  const files = readdirSync(dir).filter((f) => f.endsWith('.cgc')).map((f) => [f, new Uint8Array(readFileSync(join(dir, f)))]);
  const sphere = sphereFile();
  if (sphere) files.push(['sphere48.cgc', new Uint8Array(readFileSync(sphere))]);
  const colored = coloredSphereFile();
  if (colored) files.push(['colored32.cgc', new Uint8Array(readFileSync(colored))]);
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
