// Streams a .cgc file into the renderer: the header and section table first (one range request
// for the first HEAD_READ bytes), then the rest of the file in file order (blocks, metacells, then
// the cells in chunks), each byte requested once. Every section's CRC is checked when it is
// complete; the structure (validateStructure) as soon as the blocks and metacells are in; and each
// run of clusters is handed to the renderer once its corner records have arrived, so the first
// frame comes long before the last byte. A server that ignores Range (answers 200) still works:
// the file then arrives in one download, with a notice.

import { Crc32 } from './crc32.js';
import {
  CgcError, CgcHeader, HEAD_READ, Section, SLOT_BYTES, CLUSTER_SLOTS, BOUND_SLOT,
  checkGaps, checkSection, parseHeader, validateStructure,
} from './cgc.js';

/**
 * Bytes of one request within a section: a sixteenth of the file, between 16 KiB and 1 MiB, so
 * that even small files show clusters before their last byte and large ones need few requests.
 */
export function chunkBytes(total: number): number {
  return Math.min(1 << 20, Math.max(16 << 10, Math.ceil(total / 16)));
}

export interface ByteSource {
  name: string;
  /** Bytes [start, end); `total` is known after the first read. */
  read(start: number, end: number): Promise<Uint8Array>;
  total: number | null;
  /** Set when the server ignored Range and the whole file came in one response. */
  notice: string | null;
}

/** A local file (drag and drop): slices of the Blob. */
export function blobSource(file: File): ByteSource {
  return {
    name: file.name,
    total: file.size,
    notice: null,
    async read(start, end) {
      return new Uint8Array(await file.slice(start, end).arrayBuffer());
    },
  };
}

/** A remote file read with HTTP Range requests. `onBytes` counts bytes as they arrive. */
export function urlSource(url: string, onBytes: (n: number) => void): ByteSource {
  const name = decodeURIComponent(new URL(url, location.href).pathname.split('/').pop() || url);
  let whole: Uint8Array | null = null;
  const src: ByteSource = {
    name,
    total: null,
    notice: null,
    async read(start, end) {
      if (whole) return whole.subarray(start, Math.min(end, whole.length));
      const res = await fetch(url, { headers: { Range: `bytes=${start}-${end - 1}` } });
      if (res.status === 416 && start === 0) {
        throw new CgcError(`file is 0 bytes, shorter than the 320-byte .cgc header`);
      }
      if (!res.ok) throw new Error(`${name}: HTTP ${res.status} ${res.statusText}`);
      if (res.status === 206) {
        const m = /bytes (\d+)-(\d+)\/(\d+)/.exec(res.headers.get('Content-Range') || '');
        if (!m || Number(m[1]) !== start) throw new Error(`${name}: the server answered a range request with a wrong Content-Range`);
        src.total = Number(m[3]);
        const body = await readBody(res, onBytes);
        return body;
      }
      // 200: the server ignores Range; take the whole file once.
      src.notice = 'The server does not support range requests: the whole file is downloaded before the picture appears.';
      whole = await readBody(res, onBytes);
      src.total = whole.length;
      return whole.subarray(start, Math.min(end, whole.length));
    },
  };
  return src;
}

async function readBody(res: Response, onBytes: (n: number) => void): Promise<Uint8Array> {
  const len = Number(res.headers.get('Content-Length') || 0);
  const reader = res.body!.getReader();
  const parts: Uint8Array[] = [];
  let n = 0;
  for (;;) {
    const { done, value } = await reader.read();
    if (done) break;
    parts.push(value);
    n += value.length;
    onBytes(value.length);
  }
  const out = new Uint8Array(Math.max(n, len));
  let at = 0;
  for (const p of parts) {
    out.set(p, at);
    at += p.length;
  }
  return out.subarray(0, n);
}

export interface StreamSink {
  /** The header is parsed and valid. */
  header(h: CgcHeader): void;
  /** Clusters of slots [firstSlot, +16·counts.length) with their records are complete. */
  clusters(firstSlot: number, metacells: Uint8Array, firstCell: number, cells: Uint8Array, cellCounts: number[]): void;
  /** Bytes received so far (of the file's total). */
  progress(received: number, total: number): void;
}

/** Reads, validates and streams `src` into `sink`; resolves when every byte is in and checked. */
export async function streamCgc(src: ByteSource, sink: StreamSink, chunk?: number): Promise<CgcHeader> {
  const head = await src.read(0, HEAD_READ);
  const total = src.total ?? head.length;
  const h = parseHeader(head, total);
  const chunkSize = chunk ?? chunkBytes(total);
  sink.header(h);
  const file = new Uint8Array(total);
  file.set(head.subarray(0, Math.min(head.length, total)));
  let received = Math.min(head.length, total);
  sink.progress(received, total);

  // The requests: [received, total) cut at section boundaries and into chunks within sections.
  const cuts = new Set<number>([received, total]);
  for (const s of h.sections) {
    for (const at of [s.offset, s.offset + s.length]) if (at > received && at < total) cuts.add(at);
    for (let at = s.offset + chunkSize; at < s.offset + s.length; at += chunkSize) if (at > received) cuts.add(at);
  }
  const bounds = [...cuts].sort((a, b) => a - b);
  const crcs = new Map<Section, Crc32>(h.sections.map((s) => [s, new Crc32()]));
  const done = new Set<Section>();
  // Bytes of each section already fed to its CRC (sections may have started inside `head`).
  const fed = new Map<Section, number>(h.sections.map((s) => [s, 0]));
  let structureChecked = false;
  let clusterEnds: Int32Array | null = null; // cells end (exclusive) of each cluster
  let nextCluster = 0;

  const advance = () => {
    for (const s of h.sections) {
      const have = Math.min(Math.max(received - s.offset, 0), s.length);
      const f = fed.get(s)!;
      if (have > f) {
        crcs.get(s)!.update(file.subarray(s.offset + f, s.offset + have));
        fed.set(s, have);
      }
      if (have === s.length && !done.has(s)) {
        checkSection(s, crcs.get(s)!);
        done.add(s);
      }
    }
    if (!structureChecked && done.has(h.blocks) && done.has(h.metacells)) {
      const meta = file.subarray(h.metacells.offset, h.metacells.offset + h.metacells.length);
      validateStructure(h, file.subarray(h.blocks.offset, h.blocks.offset + h.blocks.length), meta);
      structureChecked = true;
      const m = new DataView(meta.buffer, meta.byteOffset, meta.byteLength);
      const clusters = h.slotCount / CLUSTER_SLOTS;
      clusterEnds = new Int32Array(clusters);
      for (let k = 0; k < clusters; k++) {
        let end = 0;
        for (let s = 0; s < BOUND_SLOT; s++) {
          const at = SLOT_BYTES * (k * CLUSTER_SLOTS + s);
          const mask = m.getUint16(at + 6, true);
          if (mask) {
            let n = 0;
            for (let b = 0; b < 8; b++) n += (mask >> b) & 1;
            end = m.getUint32(at + 8, true) + n;
          }
        }
        clusterEnds[k] = end;
      }
    }
    if (clusterEnds) {
      const bpc = h.precisionBits;
      const cellsIn = Math.floor(Math.min(Math.max(received - h.cells.offset, 0), h.cells.length) / bpc);
      let k = nextCluster;
      while (k < clusterEnds.length && clusterEnds[k] <= cellsIn) k++;
      if (k > nextCluster) {
        const firstCell = nextCluster === 0 ? 0 : clusterEnds[nextCluster - 1];
        const lastCell = clusterEnds[k - 1];
        const counts = [];
        for (let c = nextCluster; c < k; c++) counts.push(clusterEnds[c] - (c === 0 ? 0 : clusterEnds[c - 1]));
        const m0 = h.metacells.offset + nextCluster * CLUSTER_SLOTS * SLOT_BYTES;
        const c0 = h.cells.offset + firstCell * bpc;
        sink.clusters(
          nextCluster * CLUSTER_SLOTS,
          file.subarray(m0, m0 + (k - nextCluster) * CLUSTER_SLOTS * SLOT_BYTES),
          firstCell,
          file.subarray(c0, h.cells.offset + lastCell * bpc),
          counts,
        );
        nextCluster = k;
      }
    }
  };
  advance();
  for (let i = 0; i + 1 < bounds.length; i++) {
    const [start, end] = [bounds[i], bounds[i + 1]];
    const part = await src.read(start, end);
    if (part.length !== end - start) {
      throw new CgcError(`the file ended at ${start + part.length} bytes, before the ${total} its header promises (truncated?)`);
    }
    file.set(part, start);
    received = end;
    sink.progress(received, total);
    advance();
  }
  checkGaps(h.gaps.map(([s, e]) => file.subarray(s, e)));
  return h;
}
