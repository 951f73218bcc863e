// The packed rebuild's own thread: a worker that downloads a .cgcz and rebuilds the .cgc with
// packed.ts, answering the page's reads of the rebuilt bytes (packed-client.ts), so the range
// decoding, the viewer's largest piece of work in opening a packed file, runs beside the page's
// checks, uploads and frames instead of between them. Built into the bundle as a string
// (build.mjs) and started from a Blob URL, so the viewer stays two files.

import { CgcError } from './cgc.js';
import type { ByteSource } from './loader.js';
import { openPacked, packedSource, PackedOrigin } from './packed.js';

/** Page → worker: open the packed file (first), then reads of the rebuilt .cgc. */
export type ToWorker = { name: string; origin: PackedOrigin } | { read: number; start: number; end: number };
/** Worker → page: packed bytes downloaded, a read's bytes (with the .cgc's length) or its failure. */
export type FromWorker =
  | { downloaded: number }
  | { read: number; total: number; bytes: Uint8Array }
  | { read: number; error: string; cgc: boolean; unsupported: boolean };

const scope = self as unknown as {
  onmessage: ((e: MessageEvent<ToWorker>) => void) | null;
  postMessage(message: FromWorker, transfer?: Transferable[]): void;
};
let src: ByteSource | null = null;
scope.onmessage = (e) => {
  const m = e.data;
  if ('origin' in m) {
    src = packedSource(m.name, openPacked(m.origin, m.name), (n) => scope.postMessage({ downloaded: n }));
    return;
  }
  const opened = src!;
  opened.read(m.start, m.end).then(
    (b) => {
      // A copy of its own, handed over rather than copied again.
      const bytes = b.slice();
      scope.postMessage({ read: m.read, total: opened.total!, bytes }, [bytes.buffer]);
    },
    (err: unknown) =>
      scope.postMessage({
        read: m.read,
        error: err instanceof Error ? err.message : String(err),
        cgc: err instanceof CgcError,
        unsupported: err instanceof CgcError && err.unsupported,
      }),
  );
};
