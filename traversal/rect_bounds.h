// boxOverRect for the C++ side: the kernel is core/kernels/rect_bounds.h (shared with the
// Vulkan shaders), which says what the box bounds and how.
#pragma once

#include "traversal/prism.h"
#include "traversal/psi.h"
#include "core/kernels/rect_bounds.h"

namespace oblong {

// Frame: a LocalFrame, or anything with its P and N members (Pc, PX, PY, Nc, NX, NY)
// expressed in another orthonormal basis (tfdm's texture frame).
template <typename Frame>
inline BoxD boxOverRect(const Frame& F, double invM, const dvec2& lo, const dvec2& hi, double hlo, double hhi,
                        double pad) {
  BoxD box;
  shared::boxOverRect(F.Pc, F.PX, F.PY, F.Nc, F.NX, F.NY, invM, lo, hi, hlo, hhi, pad, box.lo, box.hi);
  return box;
}

}  // namespace oblong
