// Levels of detail of a displacement map (docs/lod.md; RMIP §2, §5 Fig. 6).
//
// Level k's samples sit on level 0's grid at (2^k i, 2^k j): the grids nest, so level
// k+1's micro-triangles are unions of level k's (same diagonal direction). Level k+1's
// heights are level k's filtered by the tent (1 2 1)/4 per axis at the even samples,
// with wrap addressing, a convex combination: every level stays within level 0's range.
// Level k exists while 2^k divides both sizes (the wrapped grid must stay periodic)
// and leaves at least 2 samples per axis.
//
// The surface at a fractional λ = k + f is docs/design.md §1's micro-geometry on level k's grid
// with heights (1 − f)·H_k + f·L_{k+1}, where L_{k+1} is level k+1's micro-geometry
// (piecewise linear on its cells) read at level k's points. At f = 1 that is level k+1's
// height field itself, so the heights are continuous in λ, and every λ is a height map
// on one grid, so the surface stays watertight across base edges.
#pragma once

#include "core/heightmap.h"

#include <memory>
#include <vector>

namespace oblong {

// The largest level of a map (0 when a size is odd).
int lodLevels(const HeightMap& m);

// Level k -> k + 1 (both sizes even): tent filter at the even samples, wrap addressing.
HeightMap downsampleLevel(const HeightMap& fine);

// Level floor(λ)'s grid with the heights of the surface at λ (0 <= λ <= lodLevels).
HeightMap heightsAtLod(const HeightMap& level0, double lambda);

// The displacement of the surface at λ, clamped to [0, lodLevels(map)]; `lod` of the
// result says the level used. The level-0 map is kept (`level0`), so a displacement can
// be moved to another λ again. λ = 0 returns the level-0 displacement itself.
Displacement atLod(const Displacement& d, float lambda);

// The level-0 displacement of a displacement at any λ.
Displacement atLevel0(const Displacement& d);

// Levels 0 .. lodLevels(level0) of a map (level 0 is the map itself).
std::vector<std::shared_ptr<const HeightMap>> lodPyramid(const std::shared_ptr<const HeightMap>& level0);

// Level k's displacement for per-ray blending (Displacement::next): `levels` from
// lodPyramid, k <= its last level (the last level has no next).
Displacement lodBand(const Displacement& level0, const std::vector<std::shared_ptr<const HeightMap>>& levels, int k);

// The level k + 1 displacement of a per-ray band at level k.
Displacement lodNextLevel(const Displacement& band);

}  // namespace oblong
