// The 16-bit code pairs of the range queries' `bits: 16` storage and the tfdm baseline's
// pyramid (strategies/quantize.h's Quantizer16 encodes them), for the CPU and the
// shaders: the join of two pairs and a code's value. Decoding monotone in the code makes the join of codes
// the code of the union.
#ifndef OBLONG_KERNELS_QUANTIZE16_H
#define OBLONG_KERNELS_QUANTIZE16_H

#include "core/kernels/lang.h"

OBLONG_KERNELS_BEGIN

// A pair is low code | high code << 16; 0xffff is the empty pair, the identity of the
// join.
OBLONG_INLINE uint joinCodes16(uint a, uint b) {
  uint lo = min(a & 0xffffu, b & 0xffffu), hi = max(a >> 16, b >> 16);
  return lo | (hi << 16);
}

// The value of a code: base + code · step, rounded twice (unfused), as Quantizer16::decode.
OBLONG_INLINE float decodeCode16(float base, float step, uint code) {
  OBLONG_PRECISE float scaled = float(code) * step;
  OBLONG_PRECISE float v = base + scaled;
  return v;
}

OBLONG_KERNELS_END

#endif
