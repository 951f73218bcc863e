// docs/benchmarks-web.md's compression figures: for each .cgc given, the bytes of each section
// (blocks, metacells, cells) and of the whole file after gzip (level 6, tower-http's default),
// brotli (quality 4, tower-http's default, and 11) and zstd (level 3, tower-http's default, and 19),
// each compressed as one stream (HTTP Content-Encoding of a whole-file response) and as
// independent 1 MiB pieces (what compressed pages in the file, or per-range encoding, would
// give); and the decode speed of each in node. gzip and brotli are node's zlib; zstd is the
// `zstd` command (node 20 has none).
// Usage: node bench/compression.mjs FILE.cgc...   (after `node build.mjs`, for build/node)
//   CODECS='gzip 6,zstd 3' limits the codecs (brotli 11 takes about 4 s per MB here).
import { readFileSync, writeFileSync, rmSync, mkdtempSync } from 'node:fs';
import { execFileSync } from 'node:child_process';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { gzipSync, gunzipSync, brotliCompressSync, brotliDecompressSync, constants } from 'node:zlib';
import { parseHeader, HEAD_READ } from '../build/node/cgc.js';

const tmp = mkdtempSync(join(tmpdir(), 'cgc-compression-'));
const zstd = (level) => (b) => {
  const f = join(tmp, 'in');
  writeFileSync(f, b);
  return execFileSync('zstd', [`-${level}`, '-q', '-c', '-T1', f], { maxBuffer: 1 << 30 });
};
const unzstd = (b) => execFileSync('zstd', ['-d', '-q', '-c'], { input: b, maxBuffer: 1 << 30 });
const br = (q) => (b) => brotliCompressSync(b, { params: { [constants.BROTLI_PARAM_QUALITY]: q, [constants.BROTLI_PARAM_SIZE_HINT]: b.length } });
const codecs = {
  'gzip 6': [(b) => gzipSync(b, { level: 6 }), gunzipSync],
  'br 4': [br(4), brotliDecompressSync],
  'br 11': [br(11), brotliDecompressSync],
  'zstd 3': [zstd(3), unzstd],
  'zstd 19': [zstd(19), unzstd],
};
if (process.env.CODECS) {
  const keep = process.env.CODECS.split(',').map((c) => c.trim());
  for (const name of Object.keys(codecs)) if (!keep.includes(name)) delete codecs[name];
}
const PIECE = 1 << 20;

for (const file of process.argv.slice(2)) {
  const bytes = new Uint8Array(readFileSync(file));
  const h = parseHeader(bytes.subarray(0, HEAD_READ), bytes.length);
  const parts = [...h.sections.map((s) => [s.name, bytes.subarray(s.offset, s.offset + s.length)]), ['whole file', bytes]];
  for (const [name, data] of parts) {
    const row = { file, part: name, bytes: data.length };
    for (const [codec, [enc, dec]] of Object.entries(codecs)) {
      const t0 = performance.now();
      const packed = enc(data);
      const encodeMs = performance.now() - t0;
      const t1 = performance.now();
      const back = dec(packed);
      const decodeMs = performance.now() - t1;
      if (Buffer.compare(Buffer.from(back), Buffer.from(data)) !== 0) throw new Error(`${codec} round trip of ${name} differs`);
      let pieces = 0;
      for (let at = 0; at < data.length; at += PIECE) pieces += enc(data.subarray(at, at + PIECE)).length;
      row[codec] = { bytes: packed.length, ratio: +(data.length / packed.length).toFixed(3), pieces1MiB: pieces, encodeMs: Math.round(encodeMs), decodeMs: Math.round(decodeMs) };
    }
    console.log(JSON.stringify(row));
  }
}
rmSync(tmp, { recursive: true });
