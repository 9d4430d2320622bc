// RMIP's range query (strategies/rmip.h; the RMIP paper §5, Eq. 5): a sample range, wrapped
// round the map and brought to RMIP pixels, is the union of the 2^p x 2^q blocks of layer
// (p, q) = floor(log2(extent)) whose corners it covers, blocks of the top built layer
// tiled over ranges beyond it, split at the border where wrapped blocks are not stored.
// Written once for Rmip::rawRange on the CPU and the Vulkan shaders.
//
// The storage is each side's own: the kernel is a function of two types, an access to the
// pyramid (RmipAccess) and an accumulator (RmipAcc), with two functions the includer
// provides for them (in GLSL, after the include: the header declares them):
//   RmipLayerRef rmipLayer(RmipAccess a, int index)     layer (p, q) at p·(Q+1) + q
//   void rmipJoin(RmipAccess a, uint entry, inout RmipAcc acc)   acc ∪= the entry's range
// In C++ they are template parameters (strategies/rmip.h: 16-bit codes joined as codes
// and decoded once, or float pairs); in GLSL macros naming the shader's types (the mesh
// record; a vec2 of decoded heights). Both joins give the same interval: decoding is
// monotone, so the decoded minimum is the minimum's decoding.
#ifndef OBLONG_KERNELS_RMIP_QUERY_H
#define OBLONG_KERNELS_RMIP_QUERY_H

#include "core/kernels/lang.h"
#include "core/kernels/texels.h"

OBLONG_KERNELS_BEGIN

// The pyramid's shape (Rmip's members): samples per pixel f, the map W x H, the pixels
// rw x rh, the top layers P and Q, the first stored layer, whether wrapped blocks are stored.
struct RmipGeom {
  int f, W, H, rw, rh, P, Q, first;
  bool wrap;
};

// One layer of the table: where its entries start, entries per row, and the shifts that
// take a block corner to its entry.
struct RmipLayerRef {
  uint offset;
  int nx, shiftX, shiftY;
};

// Where entry (ex, ey) of a layer lies: each layer is stored in tiles of 4 x 4 entries, row
// after row of tiles (a tile is one 64-byte line of 16-bit code pairs), so that a query's
// 2 x 2 corner entries share a line 9 times in 16 instead of never sharing one across two
// rows; the layer's storage is padded to whole tiles. The builders (strategies/rmip.cpp)
// place entries with the same two functions.
OBLONG_INLINE uint rmipRowBase(OBLONG_IN(RmipLayerRef) L, int ey) {
  uint tilesX = uint(L.nx + 3) >> 2u;
  return L.offset + (uint(ey) >> 2u) * tilesX * 16u + (uint(ey) & 3u) * 4u;
}
OBLONG_INLINE uint rmipColumn(int ex) { return (uint(ex) >> 2u) * 16u + (uint(ex) & 3u); }
// Entries a layer of nx x ny entries stores (whole tiles).
OBLONG_INLINE uint rmipLayerEntries(int nx, int ny) { return (uint(nx + 3) >> 2u) * (uint(ny + 3) >> 2u) * 16u; }

#ifndef __cplusplus
// The includer's functions (above), defined after this header.
RmipLayerRef rmipLayer(RmipAccess a, int index);
void rmipJoin(RmipAccess a, uint entry, inout RmipAcc acc);
#endif

// Sample axis range -> RMIP pixel range on an axis of `size` samples and n pixels: start in
// [0, n), end possibly >= n (crossing the border), or the whole axis [0, n-1].
OBLONG_INLINE void rmipToPixels(int f, int a0, int a1, int size, int n, OBLONG_OUT(int) s, OBLONG_OUT(int) e) {
  wrapAxis(a0, a1, size, s, e);
  if (f == 1) return;
  e = e < size ? e / f : n + (e - size) / f;  // the last pixel may be partial
  s /= f;
  if (e - s + 1 >= n) {
    s = 0;
    e = n - 1;
  }
}

// Pixel block [x0,x1]x[y0,y1] (x0 in [0,rw), x1 < x0 + rw; crossing only if wrap): Eq. 5,
// with blocks of the top built layer tiled over ranges beyond it. A block narrower than
// the first stored layer's uses that layer's entry at x0. Returns whether the range
// reached beyond the built layers (twice the block on an axis).
OBLONG_TEMPLATE2(RmipAccess, RmipAcc)
OBLONG_FORCE_INLINE bool rmipBlock(OBLONG_IN(RmipAccess) a, OBLONG_IN(RmipGeom) g, int x0, int x1, int y0, int y1,
                                   OBLONG_INOUT(RmipAcc) acc) {
  int p = clamp(findMSB(x1 - x0 + 1), g.first, g.P);
  int q = clamp(findMSB(y1 - y0 + 1), g.first, g.Q);
  RmipLayerRef L = rmipLayer(a, p * (g.Q + 1) + q);
  int lx = 1 << p, ly = 1 << q;
  for (int cy = y0;; cy += ly) {
    bool lastY = cy + ly - 1 >= y1;
    if (lastY) cy = max(y1 - ly + 1, y0);
    uint row = rmipRowBase(L, (cy >= g.rh ? cy - g.rh : cy) >> L.shiftY);
    for (int cx = x0;; cx += lx) {
      bool lastX = cx + lx - 1 >= x1;
      if (lastX) cx = max(x1 - lx + 1, x0);
      rmipJoin(a, row + rmipColumn((cx >= g.rw ? cx - g.rw : cx) >> L.shiftX), acc);
      if (lastX) break;
    }
    if (lastY) break;
  }
  return x1 - x0 + 1 >= 2 * lx || y1 - y0 + 1 >= 2 * ly;
}

// What a query did, for the statistics.
#define OBLONG_RMIP_BORDER_SPLIT 1  // split at the border (wrapped blocks not stored)
#define OBLONG_RMIP_BEYOND 2        // added once per block that reached beyond the built layers

// The range of samples [sx0,sx1]x[sy0,sy1] joined into acc. Returns OBLONG_RMIP_BORDER_SPLIT
// plus OBLONG_RMIP_BEYOND times the number of blocks beyond the built layers.
// One call site for rmipBlock: the shaders inline every call.
OBLONG_TEMPLATE2(RmipAccess, RmipAcc)
OBLONG_FORCE_INLINE int rmipRange(OBLONG_IN(RmipAccess) a, OBLONG_IN(RmipGeom) g, int sx0, int sy0, int sx1, int sy1,
                                  OBLONG_INOUT(RmipAcc) acc) {
  int x0, x1, y0, y1;
  rmipToPixels(g.f, sx0, sx1, g.W, g.rw, x0, x1);
  rmipToPixels(g.f, sy0, sy1, g.H, g.rh, y0, y1);
  // Wrapped blocks stored, or no crossing: one block. Else split at the border into
  // non-crossing pieces.
  bool one = g.wrap || (x1 < g.rw && y1 < g.rh);
  int na = one || x1 < g.rw ? 1 : 2, nb = one || y1 < g.rh ? 1 : 2;
  int flags = one ? 0 : OBLONG_RMIP_BORDER_SPLIT;
  for (int b = 0; b < nb; ++b)
    for (int k = 0; k < na; ++k) {
      int bx0 = k == 0 ? x0 : 0, bx1 = k == 0 ? (one ? x1 : min(x1, g.rw - 1)) : x1 - g.rw;
      int by0 = b == 0 ? y0 : 0, by1 = b == 0 ? (one ? y1 : min(y1, g.rh - 1)) : y1 - g.rh;
      if (rmipBlock(a, g, bx0, bx1, by0, by1, acc)) flags += OBLONG_RMIP_BEYOND;
    }
  return flags;
}

OBLONG_KERNELS_END

#endif
