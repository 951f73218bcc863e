// CRC-32 (IEEE 802.3, reflected, as zlib and crc32fast): the checksum of .cgc headers and sections.
// Incremental, so that a section streamed in chunks is checked without holding it twice.

// Slice-by-8: eight tables, each the previous shifted by a byte, so eight bytes take one step.
const TABLES = (() => {
  const t = new Uint32Array(8 * 256);
  for (let n = 0; n < 256; n++) {
    let c = n;
    for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
    t[n] = c >>> 0;
  }
  for (let k = 1; k < 8; k++) {
    for (let n = 0; n < 256; n++) {
      const prev = t[(k - 1) * 256 + n];
      t[k * 256 + n] = (prev >>> 8) ^ t[prev & 0xff];
    }
  }
  return t;
})();

export class Crc32 {
  private c = 0xffffffff;
  update(bytes: Uint8Array): this {
    const T = TABLES;
    const n = bytes.length;
    let c = this.c;
    let i = 0;
    for (; i + 8 <= n; i += 8) {
      const a = c ^ (bytes[i] | (bytes[i + 1] << 8) | (bytes[i + 2] << 16) | (bytes[i + 3] << 24));
      c =
        T[1792 + (a & 0xff)] ^
        T[1536 + ((a >>> 8) & 0xff)] ^
        T[1280 + ((a >>> 16) & 0xff)] ^
        T[1024 + (a >>> 24)] ^
        T[768 + bytes[i + 4]] ^
        T[512 + bytes[i + 5]] ^
        T[256 + bytes[i + 6]] ^
        T[bytes[i + 7]];
    }
    for (; i < n; i++) c = T[(c ^ bytes[i]) & 0xff] ^ (c >>> 8);
    this.c = c;
    return this;
  }
  digest(): number {
    return (this.c ^ 0xffffffff) >>> 0;
  }
}

export function crc32(bytes: Uint8Array): number {
  return new Crc32().update(bytes).digest();
}
