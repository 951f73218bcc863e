// The page's side of the packed rebuild: a ByteSource of the .cgc that packed-worker.ts rebuilds
// on its own thread, or, where no worker starts, that packed.ts rebuilds on the page's thread.

import { PACKED_WORKER } from 'isogrid:packed-worker';
import { CgcError } from './cgc.js';
import type { ByteSource } from './loader.js';
import { openPacked, packedSource, PackedOrigin } from './packed.js';
import type { FromWorker, ToWorker } from './packed-worker.js';

/** A packed file's ByteSource, and where its rebuild runs: on a worker's thread or the page's. */
export type PackedSource = ByteSource & { thread: 'worker' | 'page' };

/**
 * The .cgc that the packed file at `origin` (an absolute URL or a dropped file) rebuilds;
 * `onBytes` counts the packed bytes as they arrive.
 */
export function packedSourceOffThread(name: string, origin: PackedOrigin, onBytes: (n: number) => void): PackedSource {
  const onThread = () => packedSource(name, openPacked(origin, name), onBytes);
  const script = URL.createObjectURL(new Blob([PACKED_WORKER], { type: 'text/javascript' }));
  let worker: Worker;
  try {
    worker = new Worker(script);
  } catch {
    URL.revokeObjectURL(script);
    return Object.assign(onThread(), { thread: 'page' as const });
  }
  type Read = { start: number; end: number; resolve: (b: Uint8Array) => void; reject: (e: unknown) => void };
  const pending = new Map<number, Read>();
  let nextRead = 0;
  let heard = false;
  /** The rebuild on the page's thread, once a worker that never answered has failed. */
  let fallback: ByteSource | null = null;
  const src: PackedSource = {
    name,
    total: null,
    notice: null,
    thread: 'worker',
    read(start, end) {
      if (fallback) return fallback.read(start, end).finally(() => (src.total = fallback!.total));
      return new Promise((resolve, reject) => {
        const read = nextRead++;
        pending.set(read, { start, end, resolve, reject });
        worker.postMessage({ read, start, end } satisfies ToWorker);
      });
    },
  };
  worker.onmessage = (e: MessageEvent<FromWorker>) => {
    // Its script has loaded once it speaks.
    if (!heard) URL.revokeObjectURL(script);
    heard = true;
    const m = e.data;
    if ('downloaded' in m) {
      onBytes(m.downloaded);
      return;
    }
    const waiting = pending.get(m.read)!;
    pending.delete(m.read);
    if ('bytes' in m) {
      src.total = m.total;
      waiting.resolve(m.bytes);
    } else {
      waiting.reject(m.cgc ? new CgcError(m.error, m.unsupported) : new Error(m.error));
    }
  };
  worker.onerror = (e) => {
    worker.terminate();
    URL.revokeObjectURL(script);
    const waiting = [...pending.values()];
    pending.clear();
    if (!heard) {
      // It never started (a page that forbids workers from blob: URLs): rebuild here instead.
      fallback = onThread();
      src.thread = 'page';
      for (const w of waiting) src.read(w.start, w.end).then(w.resolve, w.reject);
      return;
    }
    const failure = new Error(`${name}: the packed rebuild's worker failed (${e.message})`);
    for (const w of waiting) w.reject(failure);
  };
  worker.postMessage({ name, origin } satisfies ToWorker);
  return src;
}
