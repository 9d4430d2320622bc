// Sample indices on a map that wraps round (core/heightmap.h), for the CPU and the shaders.
#ifndef OBLONG_KERNELS_TEXELS_H
#define OBLONG_KERNELS_TEXELS_H

#include "core/kernels/lang.h"

OBLONG_KERNELS_BEGIN

// HeightMap::wrap: i wrapped into [0, n) (GLSL's % is undefined for negative operands).
OBLONG_INLINE int wrapIndex(int i, int n) {
  if (uint(i) < uint(n)) return i;  // the common case: no division
  return i >= 0 ? i % n : n - 1 - ((-i - 1) % n);
}

// One axis [a0, a1] of a sample range on a map axis of size n: the whole axis [0, n-1]
// when the extent is >= n; else the start wrapped into [0, n) and the end relative to it
// (e may reach 2n-2: the range crosses the border).
OBLONG_INLINE void wrapAxis(int a0, int a1, int n, OBLONG_OUT(int) s, OBLONG_OUT(int) e) {
  if (a1 - a0 + 1 >= n) {
    s = 0;
    e = n - 1;
    return;
  }
  s = wrapIndex(a0, n);
  e = s + (a1 - a0);
}

OBLONG_KERNELS_END

#endif
