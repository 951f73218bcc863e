// The packed form's rebuild in node, for docs/benchmarks-web.md: for each FILE.cgcz (beside its
// FILE.cgc), `packedSource` of web/src/packed.ts rebuilding the .cgc from the packed bytes held in
// memory and handed over in 64 KiB pieces, checked byte for byte against FILE.cgc; the median and
// the spread of RUNS runs (default 3). Run `npm run build` first (it imports build/node).
// Usage: node bench/rebuild.mjs FILE.cgcz...
import { readFileSync } from 'node:fs';
import { packedSource } from '../build/node/packed.js';
import { streamOf } from '../test/fixtures.mjs';

const runs = Number(process.env.RUNS || 3);
const PIECE = 1 << 16;

for (const path of process.argv.slice(2)) {
  const packed = readFileSync(path);
  const original = readFileSync(path.replace(/\.cgcz$/, '.cgc'));
  const ms = [];
  for (let r = 0; r < runs; r++) {
    const t0 = performance.now();
    const src = packedSource(path, async () => streamOf(packed, PIECE), () => {});
    await src.read(0, 320);
    const file = await src.read(0, src.total);
    ms.push(performance.now() - t0);
    if (Buffer.compare(Buffer.from(file.buffer, file.byteOffset, file.byteLength), original) !== 0) {
      throw new Error(`${path}: the rebuilt file differs from ${path.replace(/\.cgcz$/, '.cgc')}`);
    }
  }
  ms.sort((a, b) => a - b);
  console.log(`${path}: ${packed.length} packed bytes -> ${original.length}; rebuild median ${ms[runs >> 1].toFixed(0)} ms (${ms.map((m) => m.toFixed(0)).join(', ')}), node ${process.version}`);
}
