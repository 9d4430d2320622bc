// T's texture frame: an orthonormal basis with the map's u direction (LocalFrame::PX)
// first and the face normal last, and T's P and N (LocalFrame's Pc, PX, PY, Nc, NX, NY)
// expressed in it, in float relative to Pc (boxOverRectF's frame). A box in it bounds the
// same micro-geometry as on the world's axes (the interval arithmetic holds in any
// orthonormal basis, and |N| is unchanged),
// with boxes aligned to the texels' sides and to the base surface: on a triangle that does
// not face a world axis, a height interval then bounds one side of the box instead of
// being smeared over all three (TFDM's boxes, Thonat et al. 2021 §4; docs/traversal.md).
#pragma once

#include "core/kernels/ray_patch.h"

#include "core/microgeometry.h"
#include "core/kernels/constants.h"
#include "core/kernels/lang.h"
#include "core/kernels/rect_bounds.h"
#include "core/triangle.h"
#include "traversal/psi.h"

#include <algorithm>
#include <cstdlib>

namespace oblong {

struct TextureFrame {
  dvec3 axis[3]{dvec3(1, 0, 0), dvec3(0, 1, 0), dvec3(0, 0, 1)};
  dvec3 Pc{0.0};  // P at local (0, 0): the anchor of the float box frame
  // T's P and N in this frame relative to Pc, in float, with their error scales over T's
  // cells: the frame of the traversals' per-step boxes (rect_bounds.h's boxOverRectF).
  shared::BoxFrameF box{};
  // The shaders rotate rays with the same formula (core/kernels/lang.h's dotD).
  dvec3 rot(const dvec3& v) const { return {shared::dotD(axis[0], v), shared::dotD(axis[1], v), shared::dotD(axis[2], v)}; }
  // `cells`: T's cells (cellsOverlapping); `world`: the world's axes (tfdm's `boxes:
  // "world"` ablation).
  static TextureFrame make(const LocalFrame& F, const DisplacedTriangle& T, const CellRange& cells,
                           bool world = false) {
    TextureFrame t;
    const dvec3 n = glm::cross(dvec3(T.p[1]) - dvec3(T.p[0]), dvec3(T.p[2]) - dvec3(T.p[0]));
    if (!world && glm::length(n) > 0 && glm::length(F.PX) > 0) {
      t.axis[2] = glm::normalize(n);
      t.axis[0] = glm::normalize(F.PX - glm::dot(F.PX, t.axis[2]) * t.axis[2]);
      t.axis[1] = glm::cross(t.axis[2], t.axis[0]);
    }
    t.Pc = t.rot(F.Pc);
    const ivec2 lo = ivec2(cells.x0, cells.y0) - F.origin, hi = ivec2(cells.x1, cells.y1) + 1 - F.origin;
    const dvec2 xym(std::max(std::abs(lo.x), std::abs(hi.x)), std::max(std::abs(lo.y), std::abs(hi.y)));
    t.box = shared::boxFrameF(t.rot(F.PX), t.rot(F.PY), t.rot(F.Nc), t.rot(F.NX), t.rot(F.NY),
                              invNormalLengthBound(T.minNormalLength), xym);
    return t;
  }
};

}  // namespace oblong
