// T's texture frame: an orthonormal basis with the map's u direction (LocalFrame::PX)
// first and the face normal last, and T's P and N (LocalFrame's Pc, PX, PY, Nc, NX, NY)
// expressed in it. boxOverRect on it bounds the same micro-geometry as on the world's
// axes (the interval arithmetic holds in any orthonormal basis, and |N| is unchanged),
// with boxes aligned to the texels' sides and to the base surface: on a triangle that does
// not face a world axis, a height interval then bounds one side of the box instead of
// being smeared over all three (TFDM's boxes, Thonat et al. 2021 §4; docs/traversal.md).
#pragma once

#include "core/kernels/ray_patch.h"

#include "core/microgeometry.h"
#include "core/kernels/constants.h"
#include "core/kernels/lang.h"
#include "traversal/psi.h"

namespace oblong {

struct TextureFrame {
  dvec3 axis[3]{dvec3(1, 0, 0), dvec3(0, 1, 0), dvec3(0, 0, 1)};
  dvec3 Pc{0.0}, PX{0.0}, PY{0.0}, Nc{0.0}, NX{0.0}, NY{0.0};
  // The shaders rotate rays with the same formula (core/kernels/lang.h's dotD).
  dvec3 rot(const dvec3& v) const { return {shared::dotD(axis[0], v), shared::dotD(axis[1], v), shared::dotD(axis[2], v)}; }
  // `world`: the world's axes (tfdm's `boxes: "world"` ablation).
  static TextureFrame make(const LocalFrame& F, const DisplacedTriangle& T, bool world = false) {
    TextureFrame t;
    const dvec3 n = glm::cross(dvec3(T.p[1]) - dvec3(T.p[0]), dvec3(T.p[2]) - dvec3(T.p[0]));
    if (!world && glm::length(n) > 0 && glm::length(F.PX) > 0) {
      t.axis[2] = glm::normalize(n);
      t.axis[0] = glm::normalize(F.PX - glm::dot(F.PX, t.axis[2]) * t.axis[2]);
      t.axis[1] = glm::cross(t.axis[2], t.axis[0]);
    }
    t.Pc = t.rot(F.Pc), t.PX = t.rot(F.PX), t.PY = t.rot(F.PY);
    t.Nc = t.rot(F.Nc), t.NX = t.rot(F.NX), t.NY = t.rot(F.NY);
    return t;
  }
};

}  // namespace oblong
