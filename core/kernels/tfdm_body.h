// The "tfdm" baseline's traversal of one ray and triangle (Thonat et al. 2021 §4, as
// traversal/tfdm.cpp describes it): roots, 2D node rejection, boxes, children in a fixed
// order, leaves tested with the shared micro-cells, no early exit (pruning only by the
// closest hit). No include guard and no namespace: in C++ this is the body of
// shared::TfdmLoop (core/kernels/tfdm.h), in GLSL the global scope of the tfdm.rint
// shader (render/vulkan/shaders/tfdm.glsl). What differs between the devices is reached
// through hooks, called as OBLONG_HOOK(name)(...) (C++: the derived class's member; GLSL:
// a function of that name declared before the body):
//   vec2   tfdmHeights(int L, int x, int y)   node (x, y) of level L's heights (toHeight)
//   void   tfdmBox(vec2 lo, vec2 hi, vec2 h, out vec3 blo, out vec3 bhi)  the box over
//          local rectangle [lo, hi] at heights h, in the float box frame of R
//          (core/kernels/rect_bounds.h's boxOverRectF)
//   double tfdmLimit()                       the far end of a box test: the closest hit so
//                                            far (or tmax), with its slack
//   int    tfdmLeaf(int x, int y)            tests cell (x, y)'s micro-triangles; how many

// cLo, cHi: T's cells (absolute, inclusive); origin: the absolute sample index of local
// (0, 0); S0..S2: T's uv triangle in sample coordinates; sbLo, sbHi: T's uv box in local
// sample coordinates; dl: the ray's approximate texture-space direction (child order);
// R: the ray in the boxes' float frame; t0: the near end of a box test.
void tfdmTraverse(OBLONG_IN(ivec2) cLo, OBLONG_IN(ivec2) cHi, OBLONG_IN(ivec2) origin, OBLONG_IN(dvec2) S0,
                  OBLONG_IN(dvec2) S1, OBLONG_IN(dvec2) S2, OBLONG_IN(dvec2) sbLo, OBLONG_IN(dvec2) sbHi,
                  OBLONG_IN(dvec2) dl, OBLONG_IN(BoxRayF) R, double t0,
                  OBLONG_OUT(TfdmWork) w) {
  w.boxes = 0;
  w.leaves = 0;
  w.microTris = 0;
  w.outside = 0;
  w.overflow = false;
  double sigma = tfdmSigma(S0, S1, S2);
  int ax = dl.x < 0.0 ? 1 : 0, ay = dl.y < 0.0 ? 1 : 0;
  int L0 = tfdmRootLevel(cLo, cHi);
  ivec2 r0 = ivec2(cLo.x >> L0, cLo.y >> L0), r1 = ivec2(cHi.x >> L0, cHi.y >> L0);
  ivec3 st[OBLONG_TFDM_STACK];
  int sp = 0;
  // The roots, pushed so that the first in the fixed order is popped first; they repeat
  // where T spans one node on an axis.
  for (int k = 3; k >= 0; --k) {
    ivec2 o = tfdmOrder(k, ax, ay);
    ivec2 p = ivec2(o.x != 0 ? r1.x : r0.x, o.y != 0 ? r1.y : r0.y);
    bool dup = false;
    for (int q = 0; q < k; ++q) {
      ivec2 oq = tfdmOrder(q, ax, ay);
      dup = dup || ((oq.x != 0 ? r1.x : r0.x) == p.x && (oq.y != 0 ? r1.y : r0.y) == p.y);
    }
    if (!dup) st[sp++] = ivec3(p.x, p.y, L0);
  }
  while (sp > 0) {
    ivec3 n = st[--sp];
    ivec2 clo, chi;  // the node's cells within T's
    if (!tfdmNodeCells(n.x, n.y, n.z, cLo, cHi, clo, chi)) continue;
    if (tfdmOutside(S0, S1, S2, sigma, double(clo.x), double(clo.y), double(chi.x + 1), double(chi.y + 1))) {
      ++w.outside;
      continue;
    }
    ++w.boxes;
    vec2 h = OBLONG_HOOK(tfdmHeights)(n.z, n.x, n.y);
    vec2 lo = vec2(max(dvec2(double(clo.x - origin.x), double(clo.y - origin.y)), sbLo));
    vec2 hi = vec2(min(dvec2(double(chi.x + 1 - origin.x), double(chi.y + 1 - origin.y)), sbHi));
    vec3 blo, bhi;
    OBLONG_HOOK(tfdmBox)(lo, hi, h, blo, bhi);
    double b0 = t0, b1 = OBLONG_HOOK(tfdmLimit)();
    clipBoxF(blo, bhi, R, b0, b1);
    if (!(b0 <= b1)) continue;
    if (n.z == 0) {
      ++w.leaves;
      w.microTris += OBLONG_HOOK(tfdmLeaf)(n.x, n.y);
      continue;
    }
    if (sp + 4 > OBLONG_TFDM_STACK) {
      w.overflow = true;
      break;
    }
    for (int k = 3; k >= 0; --k) {
      ivec2 o = tfdmOrder(k, ax, ay);
      st[sp++] = ivec3(2 * n.x + o.x, 2 * n.y + o.y, n.z - 1);
    }
  }
}
