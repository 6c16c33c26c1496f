#version 450
// LSD radix sort of the (cell, slot) pairs by cell, pass pc.step (digit = bits
// 8 step .. 8 step + 7), even passes from the first array to the second, odd ones
// back; pc.count = blocks of VPFFD_SORT_BLOCK pairs, one per workgroup. Two modes:
//   pc.flags 0, count: each workgroup counts its block's digits into
//     scan_buf[digit * blocks + block] (digit-major), whose exclusive scan (scan.comp)
//     is each block's first output position per digit;
//   pc.flags 1, scatter: each workgroup walks its block in chunks of
//     VPFFD_SORT_DIGITS pairs, in order; a pair goes to its block's first position for
//     its digit plus the pairs of that digit in the block's earlier chunks (s_run) plus
//     those before it in its chunk: the set bits below its own in the digit's 256-bit
//     mask of the chunk (built with atomicOr, whose result does not depend on order),
//     a few popcounts instead of a comparison with every earlier pair.
// Integer work only and stable: equal cells keep the slot order, and the result does
// not depend on scheduling.
#include "common.glsl"
layout(local_size_x = VPFFD_SORT_DIGITS) in;
#if VPFFD_SORT_DIGITS != 256
#error "a chunk of VPFFD_SORT_DIGITS pairs is described by 8 words of 32 bits per digit"
#endif
const uint MASK_WORDS = 8u;
shared uint s_count[VPFFD_SORT_DIGITS];                // count: pairs per digit
shared uint s_run[VPFFD_SORT_DIGITS];                  // scatter: pairs per digit in earlier chunks
shared uint s_mask[VPFFD_SORT_DIGITS * MASK_WORDS];    // scatter: per digit, which of the chunk's pairs have it

void count_digits(uint l, uint b, int src, int shift) {
  s_count[l] = 0u;
  barrier();
  for (uint i = l; i < uint(VPFFD_SORT_BLOCK); i += VPFFD_SORT_DIGITS) {
    const uint e = b * uint(VPFFD_SORT_BLOCK) + i;
    if (e < uint(NVERT)) atomicAdd(s_count[(uint(sorted[src + 2 * e]) >> shift) & uint(VPFFD_SORT_DIGITS - 1)], 1u);
  }
  barrier();
  scan_buf[l * uint(pc.count) + b] = s_count[l];
}

void scatter(uint l, uint b, int src, int shift) {
  const int dst = 2 * NVERT - src;
  const uint word = l / 32u, bit = l % 32u;
  s_run[l] = 0u;
  for (uint c = 0u; c < uint(VPFFD_SORT_BLOCK); c += VPFFD_SORT_DIGITS) {
    for (uint w = 0u; w < MASK_WORDS; ++w) s_mask[l * MASK_WORDS + w] = 0u;  // digit l's mask
    barrier();
    const uint e = b * uint(VPFFD_SORT_BLOCK) + c + l;
    const bool here = e < uint(NVERT);
    int key = 0, slot = 0;
    uint dg = 0u;
    if (here) {
      key = sorted[src + 2 * e];
      slot = sorted[src + 2 * e + 1];
      dg = (uint(key) >> shift) & uint(VPFFD_SORT_DIGITS - 1);
      atomicOr(s_mask[dg * MASK_WORDS + word], 1u << bit);  // OR: the same bits in any order
    }
    barrier();
    if (here) {
      // The pairs of this digit before this one in the chunk: the mask's lower bits.
      uint r = uint(bitCount(s_mask[dg * MASK_WORDS + word] & ((1u << bit) - 1u)));
      for (uint w = 0u; w < word; ++w) r += uint(bitCount(s_mask[dg * MASK_WORDS + w]));
      const uint p = scan_buf[dg * uint(pc.count) + b] + s_run[dg] + r;
      sorted[dst + 2 * p] = key;
      sorted[dst + 2 * p + 1] = slot;
    }
    barrier();  // s_run read by all before it grows
    uint n = 0u;
    for (uint w = 0u; w < MASK_WORDS; ++w) n += uint(bitCount(s_mask[l * MASK_WORDS + w]));
    s_run[l] += n;
    barrier();
  }
}

void main() {
  const uint l = gl_LocalInvocationID.x, b = gl_WorkGroupID.x;
  const int src = (pc.step & 1) * 2 * NVERT;
  const int shift = 8 * pc.step;
  if (pc.flags == 0) count_digits(l, b, src, shift);
  else scatter(l, b, src, shift);
}
