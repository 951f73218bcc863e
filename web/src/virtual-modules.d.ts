// The virtual modules web/build.mjs generates: the shaders, from crates/isogrid-gpu/shaders/modules.txt.
declare module 'isogrid:shaders' {
  export const SHADERS: Record<
    'cells' | 'probe' | 'expand' | 'ewa' | 'visibility' | 'shade' | 'mesh' | 'cells_compute' | 'ewa_compute' | 'trace_one_page' | 'trace_paged',
    string
  >;
}

// The packed rebuild's worker (packed-worker.ts) as the script text web/build.mjs bundles it into.
declare module 'isogrid:packed-worker' {
  export const PACKED_WORKER: string;
}
