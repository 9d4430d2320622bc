// Scratch: today's march's cells against the walk's, per marched piece (not committed).
#if defined(OBLONG_WALK_CHECK) && defined(__cplusplus)
// The tree before the walk had these in core/kernels/ray_patch.h and constants.h.
static bool atEnd(const CurvePoint& e, int ax, double c) {
  return abs(c - e.uv[ax]) <= e.pad[ax] * 1.0000001 + 1e-12;
}
void oldMinorAt(double c, double& wlo, double& whi) {
  int ax = g_mAx, mi = 1 - ax;
  dvec2 lo = pieceLo(g_ma, g_mb), hi = pieceHi(g_ma, g_mb);
  wlo = kInfD;
  whi = -kInfD;
  for (int k = 0; k < 2; ++k) {
    CurvePoint e = k == 0 ? g_ma : g_mb;
    if (atEnd(e, ax, c)) {
      wlo = min(wlo, e.uv[mi] - e.pad[mi]);
      whi = max(whi, e.uv[mi] + e.pad[mi]);
    }
  }
  double q2, q1, q0, w[2], rp[2];
  psiOnLine(g_psi, ax, c, q2, q1, q0);
  int n = quadraticRoots(q2, q1, q0, w, rp);
  if (n < 0) { wlo = lo[mi]; whi = hi[mi]; return; }
  for (int k = 0; k < n; ++k)
    if (w[k] >= lo[mi] - rp[k] && w[k] <= hi[mi] + rp[k]) {
      wlo = min(wlo, w[k] - rp[k]);
      whi = max(whi, w[k] + rp[k]);
    }
  if (!(wlo <= whi)) { wlo = lo[mi]; whi = hi[mi]; }
  wlo = max(wlo, lo[mi]);
  whi = min(whi, hi[mi]);
}
void walkCheck() {
  int ax = g_mAx, mi = 1 - ax;
  dvec2 lo = pieceLo(g_ma, g_mb), hi = pieceHi(g_ma, g_mb);
  OBLONG_PRECISE double mLo = lo[mi] - g_eps[mi], mHi = hi[mi] + g_eps[mi];
  OBLONG_PRECISE double etaMax = 2.0 * OBLONG_TRAV_SNAP_ETA * (1.0 + 2.0 * max(abs(mLo), abs(mHi)));
  bool oneRow = floor(mLo - etaMax) == floor(mHi + etaMax);
  bool ends = (atEnd(g_ma, ax, lo[ax]) && atEnd(g_mb, ax, hi[ax])) || (atEnd(g_mb, ax, lo[ax]) && atEnd(g_ma, ax, hi[ax]));
  std::set<std::pair<int, int>> olds, news;
  for (int k = g_gLo[ax]; k <= g_gHi[ax]; ++k) {
    OBLONG_PRECISE double c0 = max(double(k) - g_eps[ax], lo[ax]), c1 = min(double(k + 1) + g_eps[ax], hi[ax]);
    if (c0 > c1) continue;
    double r[4];
    if (oneRow || (ends && c0 == lo[ax] && c1 == hi[ax])) { r[0] = lo[mi]; r[1] = hi[mi]; r[2] = lo[mi]; r[3] = hi[mi]; }
    else for (int q = 0; q < 2; ++q) oldMinorAt(q == 0 ? c0 : c1, r[2 * q], r[2 * q + 1]);
    OBLONG_PRECISE double wlo = min(r[0], r[2]) - g_eps[mi], whi = max(r[1], r[3]) + g_eps[mi];
    OBLONG_PRECISE double eta = OBLONG_TRAV_SNAP_ETA * (1.0 + abs(wlo) + abs(whi));
    int j0 = max(int(floor(wlo - eta)), g_gLo[mi]), j1 = min(int(floor(whi + eta)), g_gHi[mi]);
    for (int j = j0; j <= j1; ++j) olds.insert(ax == 0 ? std::make_pair(k, j) : std::make_pair(j, k));
  }
  // The walk without its stop.
  int sK = g_mK, sJ = g_mJ, sJ0 = g_mJ0, sJ1 = g_mJ1, sP0 = g_mPLo, sP1 = g_mPHi, sC0 = g_mCLo, sC1 = g_mCHi;
  bool sCol = g_mCol, sRun = g_mRun, sSet = g_mStopSet;
  bvec2 sAxis = g_mStopAxis;
  g_mStopSet = true;
  g_mStopAxis = bvec2(false, false);
  int ci, cj, guard = 0;
  while (nextCell(ci, cj) && ++guard < 10000000) news.insert({ci, cj});
  g_mK = sK; g_mJ = sJ; g_mJ0 = sJ0; g_mJ1 = sJ1; g_mPLo = sP0; g_mPHi = sP1; g_mCLo = sC0; g_mCHi = sC1;
  g_mCol = sCol; g_mRun = sRun; g_mStopSet = sSet; g_mStopAxis = sAxis;
  size_t missing = 0;
  for (const auto& c : olds) missing += !news.count(c);
  walkStats().pieces += 1;
  walkStats().oldCells += olds.size();
  walkStats().newCells += news.size();
  walkStats().missing += missing;
  if (missing && walkStats().reported++ < 5)
    std::fprintf(stderr, "WALKCHECK missing %zu of %zu (new %zu) ax %d sa %d sm %d a (%.17g %.17g ±%g %g) b (%.17g %.17g ±%g %g) eps %g %g\n",
                 missing, olds.size(), news.size(), ax, g_mSa, g_mSm, g_ma.uv.x, g_ma.uv.y, g_ma.pad.x, g_ma.pad.y,
                 g_mb.uv.x, g_mb.uv.y, g_mb.pad.x, g_mb.pad.y, g_eps.x, g_eps.y);
  if (missing && walkStats().reported <= 5) {
    std::fprintf(stderr, "  R %d %d..%d %d S %d %d..%d %d E %d %d..%d %d g %d %d..%d %d any %d all %d K %d\n", g_mRLo.x, g_mRLo.y, g_mRHi.x, g_mRHi.y,
                 g_mSLo.x, g_mSLo.y, g_mSHi.x, g_mSHi.y, g_mELo.x, g_mELo.y, g_mEHi.x, g_mEHi.y, g_gLo.x, g_gLo.y, g_gHi.x, g_gHi.y, int(g_mAny), int(g_mAll), g_mK);
    std::fprintf(stderr, "  psi %.17g %.17g %.17g %.17g %.17g %.17g Q1 %.9g %.9g %.9g Q2 %.9g %.9g %.9g err %g rect %g %g %g %g dil %g %g\n",
                 g_psi.c0, g_psi.cX, g_psi.cY, g_psi.cXX, g_psi.cXY, g_psi.cYY, g_mQ1.x, g_mQ1.y, g_mQ1.z, g_mQ2.x, g_mQ2.y, g_mQ2.z, g_mErr,
                 g_mRectLo.x, g_mRectLo.y, g_mRectHi.x, g_mRectHi.y, g_mDil.x, g_mDil.y);
    for (const auto& c : olds) std::fprintf(stderr, "  old cell %d %d in new %d\n", c.first, c.second, int(news.count(c)));
  }
}
#endif
