#!/usr/bin/env python3
"""Groups callgrind_annotate's per-function self costs (Ir) into the traversal's stages."""
import re, sys
STAGES = [
    ("tfdm (nodes, leaves)", r"Tfdm|tfdm|CellPyramid"),
    ("box (boxOverRect, clipBox)", r"boxOverRect|clipBox|clipToBox|clipToCells"),
    ("range query (RMIP)", r"rawRange|Rmip::|RangeQueryImpl|rmip"),
    ("micro-triangles (cells' vertices, watertight tests)", r"MicroCells|gridInterior|clippedCell|interiorCorners|ClosestHit|testMicro|watertight|GridVertexCache|microTri|MicroTri|mcWorld|mcVertex"),
    ("march (columns, ψ's roots, cell loop, snap)", r"::march|minorAt|testCell|testCells|::snap|quadraticRoots|atEnd"),
    ("curve pieces (splits, crossings, claims, inversions)", r"processPiece|crossing|makePoint|claim|pointBetween|pointFromHit|split|Newton|newton|invert|Cubic|cubic|Midpoint|pushPiece|pointAt"),
    ("box subdivision (wide-ε leaves, box-only prisms)", r"processBox|::leaf$|pushBox|runBoxOnly"),
    ("prism entry (crossings, ψ, set-up)", r"prismCrossings|RayPatch::run|RayPatch::RayPatch|Traversal::|TraversalIntersector|missesPrism|Psi|psi|LocalFrame|rotate|addCrossing|::intersect$|TextureFrame|monotoneSplits"),
    ("Embree (BVH over prisms)", r"embree|rtc|BVH|bvh|avx|sse"),
]
tot = 0; per = {}; other = {}
for line in open(sys.argv[1]):
    m = re.match(r"\s*([\d,]+)\s", line)
    f = re.search(r"(?:\?\?\?|/\S*?|[\w.+-]+\.\w+):(\S.*)$", line)
    if not m or not f or "PROGRAM TOTALS" in line or "file:function" in line: continue
    ir = int(m.group(1).replace(",", "")); full = f.group(1)
    name = full.replace("(anonymous namespace)", "anon").split("(")[0]  # qualified name, no template arguments
    while "<" in name:
        name2 = re.sub(r"<[^<>]*>", "", name)
        if name2 == name: break
        name = name2
    tot += ir
    for st, rx in STAGES:
        if re.search(rx, name): per[st] = per.get(st, 0) + ir; break
    else:
        other[name[:110]] = other.get(name[:110], 0) + ir
per["other"] = sum(other.values())
for st, _ in STAGES + [("other", "")]:
    if per.get(st): print(f"{100*per[st]/tot:5.1f} %  {st}")
if "-v" in sys.argv and other:
    for k, v in sorted(other.items(), key=lambda kv: -kv[1])[:15]: print(f"   other {100*v/tot:5.1f} % {k}")
print(f"total Ir {tot:,}")
