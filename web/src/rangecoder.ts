// The decoding side of the packed form's entropy coder and its symbol models: the coder and the
// models of crates/isogrid/src/cgc/range_coder.rs (its module doc says how they work), which
// packs what this decodes; web/test/packed.test.mjs rebuilds files it packed, byte for byte.

import { CgcError } from './cgc.js';

const PROB_BITS = 12;
const MOVE_BITS = 5;
const PROB_ONE = 1 << PROB_BITS;
const PROB_HALF = 1 << (PROB_BITS - 1);
const TOP = 2 ** 24;

/** Reads bits under adaptive probabilities from one chunk's bytes. */
export class RangeDecoder {
  // The range and the code are unsigned 32-bit numbers kept in int32 variables (x | 0), which
  // the engine holds as machine integers; unsigned comparisons flip the sign bit first.
  private range = -1;
  private code = 0;
  private at = 1;
  constructor(private readonly b: Uint8Array) {
    if (b.length < 5 || b[0] !== 0) throw new CgcError('a chunk of the packed block stream does not start as one (damaged)');
    this.code = (b[1] << 24) | (b[2] << 16) | (b[3] << 8) | b[4];
    this.at = 5;
  }

  /** Whether every byte of the chunk was used. */
  get finished(): boolean {
    return this.at === this.b.length;
  }

  /** The next bit under `probs[i]`, which it then moves towards that bit. */
  bit(probs: Uint16Array, i: number): number {
    const p = probs[i];
    const bound = Math.imul(this.range >>> PROB_BITS, p);
    let bit: number;
    if ((this.code ^ 0x80000000) < (bound ^ 0x80000000)) {
      this.range = bound;
      probs[i] = p + ((PROB_ONE - p) >> MOVE_BITS);
      bit = 0;
    } else {
      this.code = (this.code - bound) | 0;
      this.range = (this.range - bound) | 0;
      probs[i] = p - (p >> MOVE_BITS);
      bit = 1;
    }
    if ((this.range ^ 0x80000000) < (TOP ^ 0x80000000)) {
      if (this.at >= this.b.length) throw new CgcError('a chunk of the packed block stream ends early (damaged)');
      // A coder's code always lies below its range; past that the bytes are not its output.
      if ((this.code ^ 0x80000000) >= (this.range ^ 0x80000000)) throw new CgcError('the packed block stream is damaged (not the coder\'s output)');
      this.range <<= 8;
      this.code = (this.code << 8) | this.b[this.at++];
    }
    return bit;
  }
}

/** Probabilities of the symbols of `bits` bits under each of `contexts` contexts. */
export class BitTree {
  private readonly probs: Uint16Array;
  constructor(private readonly bits: number, contexts: number) {
    this.probs = new Uint16Array(contexts << bits).fill(PROB_HALF);
  }
  decode(d: RangeDecoder, context: number): number {
    const base = context << this.bits;
    let node = 1;
    for (let i = 0; i < this.bits; i++) node = 2 * node + d.bit(this.probs, base + node);
    return node - (1 << this.bits);
  }
}

/** Bit length of `u` (below 2^32): 0 for 0, else the position of its leading one, plus one. */
export function bitLength(u: number): number {
  return 32 - Math.clz32(u);
}

/** Integers of up to `maxLength` bits: their length under a context, then the bits below the leading one. */
export class LengthCoded {
  private readonly lengths: BitTree;
  private readonly mantissa: Uint16Array;
  constructor(private readonly maxLength: number, contexts: number) {
    this.lengths = new BitTree(bitLength(maxLength), contexts);
    this.mantissa = new Uint16Array((maxLength + 1) * Math.max(1, maxLength)).fill(PROB_HALF);
  }
  decode(d: RangeDecoder, context: number): number {
    const length = this.lengths.decode(d, context);
    if (length > this.maxLength) throw new CgcError('a packed number is longer than its field (damaged)');
    if (length === 0) return 0;
    let u = 1;
    for (let i = length - 2; i >= 0; i--) u = 2 * u + d.bit(this.mantissa, length * this.maxLength + i);
    return u;
  }
}

/** Contexts of a residual's length (range_coder.rs's RESIDUAL_CONTEXTS). */
const RESIDUAL_CONTEXTS = 16 * 16;
/** Contexts of a Morton step's length (range_coder.rs's STEP_CONTEXTS). */
const STEP_CONTEXTS = 13;

/** The context of a residual from the previous residual's length and its neighbours' spread. */
export function residualContext(previousLength: number, spread: number): number {
  return Math.min(previousLength, 15) * 16 + Math.min(bitLength(spread), 15);
}

/** The residual (modulo max + 1) that fold_residual of range_coder.rs folded into `u` (u <= max). */
export function unfoldResidual(u: number, max: number): number {
  return u % 2 === 0 ? u / 2 : max + 1 - (u + 1) / 2;
}

/** The models of the block stream, one per field (range_coder.rs's BlockModels). */
export class BlockModels {
  readonly counts = new BitTree(4, 1);
  readonly steps = new LengthCoded(11, STEP_CONTEXTS);
  readonly masks = new BitTree(8, 256);
  readonly modes = new BitTree(1, 2);
  readonly residuals: LengthCoded;
  readonly attribute: BitTree;
  constructor(bits: number, attributeWidth: number) {
    this.residuals = new LengthCoded(bits, RESIDUAL_CONTEXTS);
    this.attribute = new BitTree(8, 256 * Math.max(1, attributeWidth));
  }
}
