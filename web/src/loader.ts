// Streams a .cgc file into the renderer: the header and section table first (one range request
// for the first HEAD_READ bytes), then the rest of the file in file order (blocks, metacells, then
// the cells in chunks), each byte requested once, two requests in flight once the first clusters
// are drawn (one at a time before, and none past them until they are). Every section's CRC is checked when it is
// complete; the structure (validateStructure) as soon as the blocks and metacells are in; and each
// run of clusters is handed to the renderer once its corner records have arrived, so the first
// frame comes long before the last byte. A server that ignores Range (answers 200) still works:
// the file then arrives in one download, with a notice.

import { Crc32 } from './crc32.js';
import {
  CgcError, CgcHeader, HEAD_READ, Section, SLOT_BYTES, CLUSTER_SLOTS, BOUND_SLOT, ATTRIBUTE_HEAD_SIZE, AttributeInfo,
  BorderCheck, CellAttribute, GridLabels, WorldFrame, checkGaps, checkLabels, checkSection, parseAttribute, parseAttributeHead, parseHeader, parseWorldFrame, readLabels,
  StructureCheck,
} from './cgc.js';

/**
 * Bytes of one request within a section: a 32nd of the file, between 16 KiB and 1 MiB, so
 * that even small files show clusters before their last byte and large ones need few requests.
 */
export function chunkBytes(total: number): number {
  return Math.min(1 << 20, Math.max(16 << 10, Math.ceil(total / 32)));
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

/**
 * `src` with its first read (the header and table, [0, HEAD_READ)) already started, so that the
 * request overlaps what the page does before streaming (opening the GPU device).
 */
export function withHeadStarted(src: ByteSource): ByteSource {
  const head = src.read(0, HEAD_READ);
  head.catch(() => {}); // thrown where streamCgc takes it
  let first = true;
  return {
    name: src.name,
    get total() {
      return src.total;
    },
    get notice() {
      return src.notice;
    },
    read(start, end) {
      if (first && start === 0 && end === HEAD_READ) {
        first = false;
        return head;
      }
      return src.read(start, end);
    },
  };
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
  /**
   * Settles once the first clusters handed over have been drawn (a frame of them started). The
   * loader requests nothing more until then, so that the first frame shows what the first bytes
   * give rather than whatever arrived while the renderer was getting ready (compiling its
   * pipelines takes seconds on a CPU adapter, longer than a fast link needs for the whole file).
   */
  drawn?(): Promise<void>;
  /**
   * Whether no border sample of the clusters so far is inside (BorderCheck: back-face culling is
   * safe): told once the blocks are in, and again, before the clusters that change it, if it turns false.
   */
  borderOutside?(outside: boolean): void;
  /** The cell attribute's head (checked), as soon as it has arrived. */
  attributeHead?(info: AttributeInfo): void;
  /**
   * Stored values [first, first + n) of the cell attribute (n = bytes / (bits / 8)), handed over
   * before the clusters whose cells they colour.
   */
  attributeValues?(first: number, values: Uint8Array): void;
  /** The whole cell attribute, once its section is complete and checked. */
  attribute?(a: CellAttribute): void;
  /**
   * The labels, once their sections are complete and checked on their own (before the metacells:
   * their checks against the metacells follow, and fail the stream if the labels do not hold).
   */
  labels?(l: GridLabels): void;
  /** The convention of the header's origin and directions, once its section is in and checked. */
  worldFrame?(frame: WorldFrame): void;
}

/**
 * Reads, validates and streams `src` into `sink`; resolves when every byte is in and checked.
 * Request order: the header (and table), the sections before the metacells (the blocks) and the
 * label sections (4 B per cluster and a few per label: colours and the index from the start), then
 * metacells, cells and the cell attribute interleaved — the next chunk of the attribute while it
 * covers fewer records than the cells fetched, else the next chunk of cells as soon as the
 * metacells checked so far point at cells not yet fetched, else the next chunk of metacells — then
 * the rest. A cluster is handed over once its corner records and, with an attribute, their values
 * have arrived, so it is drawn in its colours from the start. Each byte is requested once.
 */
export async function streamCgc(src: ByteSource, sink: StreamSink, chunk?: number): Promise<CgcHeader> {
  const head = await src.read(0, HEAD_READ);
  const total = src.total ?? head.length;
  const h = parseHeader(head, total);
  sink.header(h);
  const chunkSize = chunk ?? chunkBytes(total);
  const file = new Uint8Array(total);
  const headLength = Math.min(head.length, total);
  file.set(head.subarray(0, headLength));
  let received = headLength;
  sink.progress(received, total);

  // The requests: [headLength, total) cut at section boundaries and into chunks within sections.
  const cuts = new Set<number>([headLength, total]);
  for (const s of h.sections) {
    for (const at of [s.offset, s.offset + s.length]) if (at > headLength && at < total) cuts.add(at);
    for (let at = s.offset + chunkSize; at < s.offset + s.length; at += chunkSize) if (at > headLength) cuts.add(at);
  }
  const bounds = [...cuts].sort((a, b) => a - b);
  const within = (s: Section, start: number) => start >= s.offset && start < s.offset + s.length;
  const pieces = bounds.slice(0, -1).map((start, i) => [start, bounds[i + 1]] as [number, number]);
  const metaPieces = pieces.filter(([a]) => within(h.metacells, a));
  const cellPieces = pieces.filter(([a]) => within(h.cells, a));
  const attr = h.attribute;
  const attrPieces = attr ? pieces.filter(([a]) => within(attr, a)) : [];
  const early = (a: number) => a < h.metacells.offset || (h.labels ?? []).some((s) => within(s, a));
  const rest = pieces.filter(([a]) => !within(h.metacells, a) && !within(h.cells, a) && !(attr && within(attr, a)));
  const before = rest.filter(([a]) => early(a));
  const after = rest.filter(([a]) => !early(a));

  const crcs = new Map<Section, Crc32>(h.sections.map((s) => [s, new Crc32()]));
  const done = new Set<Section>();
  // Bytes of each section received from its start (each section's pieces arrive in order).
  const have = new Map<Section, number>(h.sections.map((s) => [s, Math.min(Math.max(headLength - s.offset, 0), s.length)]));
  const fed = new Map<Section, number>(h.sections.map((s) => [s, 0]));
  const blocks = file.subarray(h.blocks.offset, h.blocks.offset + h.blocks.length);
  const meta = file.subarray(h.metacells.offset, h.metacells.offset + h.metacells.length);
  const structure = new StructureCheck(h, blocks, meta);
  const m = new DataView(meta.buffer, meta.byteOffset, meta.byteLength);
  const bpc = h.precisionBits;
  const clusterEnds: number[] = []; // cells end (exclusive) of each checked cluster
  let nextCluster = 0; // clusters handed to the sink
  let border: BorderCheck | null = null;
  let labels: GridLabels | null = null;
  let labelsChecked = !h.labels;
  let attributeOut = !h.attribute;
  let frameOut = !h.worldFrame;
  const part = (s: Section) => file.subarray(s.offset, s.offset + s.length);
  let attrInfo: AttributeInfo | null = null;
  let attrFed = 0; // attribute values handed to the sink
  /** Attribute values arrived (all records when there is no attribute); checks the head first. */
  const valuesIn = (): number => {
    if (!attr) return Infinity;
    if (!attrInfo) {
      if (have.get(attr)! < ATTRIBUTE_HEAD_SIZE) return 0;
      attrInfo = parseAttributeHead(part(attr)).info;
      sink.attributeHead?.(attrInfo);
    }
    return Math.min(h.activeCells, Math.floor((have.get(attr)! - ATTRIBUTE_HEAD_SIZE) / (attrInfo.bits / 8)));
  };

  const advance = () => {
    for (const s of h.sections) {
      const got = have.get(s)!;
      const f = fed.get(s)!;
      if (got > f) {
        crcs.get(s)!.update(file.subarray(s.offset + f, s.offset + got));
        fed.set(s, got);
      }
      if (got === s.length && !done.has(s)) {
        checkSection(s, crcs.get(s)!);
        done.add(s);
      }
    }
    const values = valuesIn();
    if (attrInfo && values > attrFed) {
      const w = attrInfo.bits / 8;
      sink.attributeValues?.(attrFed, part(attr!).subarray(ATTRIBUTE_HEAD_SIZE + attrFed * w, ATTRIBUTE_HEAD_SIZE + values * w));
      attrFed = values;
    }
    if (!attributeOut && done.has(attr!)) {
      attributeOut = true;
      const attribute = parseAttribute(part(attr!), h.activeCells); // checked whether or not the sink takes it
      sink.attribute?.(attribute);
    }
    if (!frameOut && done.has(h.worldFrame!)) {
      frameOut = true;
      const frame = parseWorldFrame(part(h.worldFrame!)); // checked whether or not the sink takes it
      sink.worldFrame?.(frame);
    }
    if (h.labels && !labels && h.labels.every((s) => done.has(s))) {
      labels = readLabels(part(h.labels[0]), part(h.labels[1]), part(h.labels[2]), h.slotCount / CLUSTER_SLOTS);
      sink.labels?.(labels);
    }
    if (!done.has(h.blocks)) return;
    if (!border) {
      border = new BorderCheck(h, blocks);
      sink.borderOutside?.(border.outside);
    }
    const checked = structure.advance(Math.floor(have.get(h.metacells)! / SLOT_BYTES));
    if (!labelsChecked && labels && checked === h.slotCount && done.has(h.metacells)) {
      labelsChecked = true;
      checkLabels(labels, meta);
    }
    for (let k = clusterEnds.length; k < checked / CLUSTER_SLOTS; k++) {
      let end = k === 0 ? 0 : clusterEnds[k - 1];
      for (let s = 0; s < BOUND_SLOT; s++) {
        const at = SLOT_BYTES * (k * CLUSTER_SLOTS + s);
        const mask = m.getUint16(at + 6, true);
        if (mask) {
          let n = 0;
          for (let b = 0; b < 8; b++) n += (mask >> b) & 1;
          end = m.getUint32(at + 8, true) + n;
        }
      }
      clusterEnds.push(end);
    }
    const cellsIn = Math.min(Math.floor(have.get(h.cells)! / bpc), values);
    let k = nextCluster;
    while (k < clusterEnds.length && clusterEnds[k] <= cellsIn) k++;
    if (k > nextCluster) {
      const firstCell = nextCluster === 0 ? 0 : clusterEnds[nextCluster - 1];
      const counts = [];
      for (let c = nextCluster; c < k; c++) counts.push(clusterEnds[c] - (c === 0 ? 0 : clusterEnds[c - 1]));
      const m0 = h.metacells.offset + nextCluster * CLUSTER_SLOTS * SLOT_BYTES;
      const slots = file.subarray(m0, m0 + (k - nextCluster) * CLUSTER_SLOTS * SLOT_BYTES);
      const records = file.subarray(h.cells.offset + firstCell * bpc, h.cells.offset + clusterEnds[k - 1] * bpc);
      const wasOutside = border.outside;
      border.add(slots, firstCell, records);
      if (border.outside !== wasOutside) sink.borderOutside?.(border.outside);
      sink.clusters(nextCluster * CLUSTER_SLOTS, slots, firstCell, records, counts);
      nextCluster = k;
    }
  };
  /** Takes in a piece that has arrived: its bytes, the counts, the checks and the hand-over. */
  const takePiece = ([start, end]: [number, number], part: Uint8Array) => {
    if (part.length !== end - start) {
      throw new CgcError(`the file ended at ${start + part.length} bytes, before the ${total} its header promises (truncated?)`);
    }
    file.set(part, start);
    received += end - start;
    for (const s of h.sections) if (within(s, start)) have.set(s, end - s.offset);
    sink.progress(received, total);
    advance();
  };
  // Bytes of each section requested so far (its pieces are requested in order).
  const issued = new Map<Section, number>(have);
  const requestedOf = (s: Section | null) => (s ? issued.get(s)! : 0);
  /** The next piece to request, by the order above, judged on what has been requested. */
  const nextPiece = (): [number, number] | undefined => {
    if (before.length) return before.shift();
    if (metaPieces.length || cellPieces.length || attrPieces.length) {
      const gridLeft = metaPieces.length || cellPieces.length;
      const cellsRequested = Math.floor(requestedOf(h.cells) / bpc);
      // Values requested (a head requested but not yet read counts as ahead of the cells).
      const valuesRequested = attrInfo
        ? Math.floor((requestedOf(attr) - ATTRIBUTE_HEAD_SIZE) / (attrInfo.bits / 8))
        : requestedOf(attr) > 0 ? Infinity : 0;
      if (attrPieces.length && (!gridLeft || valuesRequested < cellsRequested)) return attrPieces.shift();
      // The cells the metacells requested point at: those checked exactly, those still in flight
      // at the file's mean cells per slot.
      const checkedCells = clusterEnds.length ? clusterEnds[clusterEnds.length - 1] : 0;
      const inFlightSlots = (requestedOf(h.metacells) - have.get(h.metacells)!) / SLOT_BYTES;
      const cellsWanted = (checkedCells + Math.ceil((inFlightSlots * h.activeCells) / Math.max(h.slotCount, 1))) * bpc;
      const cellsFirst = cellPieces.length && (!metaPieces.length || requestedOf(h.cells) < cellsWanted);
      return (cellsFirst ? cellPieces : metaPieces).shift();
    }
    return after.shift();
  };
  // Two requests in flight, taken in the order they were made: the link is not idle while a
  // piece is checked and handed over, nor for each request's round trip.
  const inFlight: { piece: [number, number]; bytes: Promise<Uint8Array> }[] = [];
  const request = (): boolean => {
    const piece = nextPiece();
    if (!piece) return false;
    for (const s of h.sections) if (within(s, piece[0])) issued.set(s, piece[1] - s.offset);
    const bytes = src.read(piece[0], piece[1]);
    bytes.catch(() => {}); // a failure is thrown where the piece is taken, not as an unhandled rejection
    inFlight.push({ piece, bytes });
    return true;
  };
  advance();
  // Until the first clusters are drawn (`sink.drawn`), one request at a time and none after them.
  let opened = !sink.drawn;
  for (;;) {
    while (inFlight.length < (opened ? 2 : 1) && request());
    if (!inFlight.length) break;
    const { piece, bytes } = inFlight.shift()!;
    takePiece(piece, await bytes);
    if (!opened && nextCluster > 0) {
      await sink.drawn!();
      opened = true;
    }
  }
  structure.finish();
  if (!labelsChecked) throw new CgcError('the label sections were never checked against the metacells');
  checkGaps(h.gaps.map(([s, e]) => file.subarray(s, e)));
  return h;
}
