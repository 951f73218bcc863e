// The virtual module web/build.mjs generates from crates/isogrid-gpu/shaders/modules.txt.
declare module 'isogrid:shaders' {
  export const SHADERS: Record<
    'cells' | 'probe' | 'expand' | 'ewa' | 'visibility' | 'shade' | 'mesh' | 'cells_compute' | 'ewa_compute' | 'trace_one_page' | 'trace_paged',
    string
  >;
}
