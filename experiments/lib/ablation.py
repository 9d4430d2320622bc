"""One-component ablations from the canonical configuration (rmip full resolution +
newton + midpoint2d, marching scale 4, inversion on): every other part fixed, one
strategy swapped. Used by experiments/ablation_{range_query,splitter,inverter}/run.py.

Besides the timings, the rendered images are compared pixel by pixel with the canonical
one (same seed): every configuration is exact, so they should agree except where two
micro-triangles are hit at exactly the same t (ties may be broken differently).
"""
import common as C

# Component -> (flag, registry kind); the strategies come from the binary's registry, the
# canonical one first.
COMPONENTS = {
    "range_query": ("--range", "range"),
    "splitter": ("--splitter", "splitter"),
    "inverter": ("--inverter", "inverter"),
}


def run(ctx, component: str) -> dict:
    import numpy as np

    flag, kind = COMPONENTS[component]
    names = C.strategy_names(ctx, kind)
    scenes = ctx.pick(["asteroid", "quad_tiled", "sphere", "terrain"], ["asteroid"])
    names = ctx.pick(names, names)
    integ = "path"
    size = ctx.pick("240x180", "32x24")
    reps = ctx.reps(3, 1)
    jobs = []
    for s in scenes:
        for n in names:
            jobs.append((f"{s}/{n}", "render", C.scene_path(s),
                         [flag, n, "--integrator", integ, "--size", size, "-o", ctx.tmp(f"{s}_{n}.png")]))
    ctx.log(f"{len(jobs)} configurations x {reps} rounds")
    res = C.interleaved(ctx, jobs, reps)

    plt = C.plt()
    rows = []
    for s in scenes:
        base = res[f"{s}/{names[0]}"]
        img0 = plt.imread(ctx.tmp(f"{s}_{names[0]}.png"))
        for n in names:
            rs = res[f"{s}/{n}"]
            st = rs[0].stats
            rel = [r.seconds / b.seconds for r, b in zip(rs, base)]  # time relative to canonical, per round
            img = plt.imread(ctx.tmp(f"{s}_{n}.png"))
            diff = int(np.any(img != img0, axis=-1).sum()) if img.shape == img0.shape else -1
            nr = st["rays"]["primary"] + st["rays"]["secondary"]
            rc = st["ray_counters"]
            rows.append({"scene": s, "component": component, "strategy": n, "geometry": st["geometry"],
                         "time_vs_canonical_median": C.med(rel), "min": min(rel), "max": max(rel),
                         "render_s_median": C.med([r.seconds for r in rs]),
                         "steps_per_ray": rc["steps_per_ray"], "boxes_per_ray": rc["boxes"] / nr,
                         "cells_per_ray": rc["cells_marched"] / nr, "inversions_per_ray": rc["inversions"] / nr,
                         "prisms_per_ray": rc["prisms"] / nr, "range_bytes": C.range_bytes(st),
                         "total_bytes": C.total_bytes(st), "pixels_differing_from_canonical": diff,
                         "pixels": img0.shape[0] * img0.shape[1], "rounds": len(rel)})
    C.write_csv(ctx.out / "results.csv", rows)

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.4))
    wbar = 0.8 / len(names)
    for i, n in enumerate(names):
        pts = [next(r for r in rows if r["scene"] == s and r["strategy"] == n) for s in scenes]
        xs = [j + (i - (len(names) - 1) / 2) * wbar for j in range(len(scenes))]
        axes[0].bar(xs, [r["time_vs_canonical_median"] for r in pts], wbar, label=n,
                    yerr=[[r["time_vs_canonical_median"] - r["min"] for r in pts],
                          [r["max"] - r["time_vs_canonical_median"] for r in pts]], capsize=2)
        axes[1].bar(xs, [r["steps_per_ray"] for r in pts], wbar, label=n)
    axes[0].axhline(1, color="k", lw=0.8)
    axes[0].set_ylabel(f"render time / {names[0]}'s (median, range)")
    axes[1].set_ylabel("steps per ray (boxes + cells)")
    for ax in axes:
        ax.set_xticks(range(len(scenes)), scenes)
        ax.grid(True, axis="y", alpha=0.3)
        ax.legend(fontsize=7)
    axes[0].set_title(f"{component} ablation: time ({integ} {size}, 1 thread)")
    axes[1].set_title("work per ray")
    fig.tight_layout()
    fig.savefig(ctx.out / f"ablation_{component}.png")

    header = ["scene", "strategy", "time / canonical (median, range)", "steps/ray", "boxes/ray", "cells/ray",
              "inversions/ray", "prisms/ray", "range-query memory", "pixels ≠ canonical"]
    trows = [[r["scene"], r["strategy"], f"{r['time_vs_canonical_median']:.2f} ({r['min']:.2f}–{r['max']:.2f})",
              f"{r['steps_per_ray']:.2f}", f"{r['boxes_per_ray']:.2f}", f"{r['cells_per_ray']:.2f}",
              f"{r['inversions_per_ray']:.2f}", f"{r['prisms_per_ray']:.2f}", C.fmt_bytes(r["range_bytes"]),
              f"{r['pixels_differing_from_canonical']} / {r['pixels']}"] for r in rows]
    parts = []
    for n in names[1:]:
        xs = [r["time_vs_canonical_median"] for r in rows if r["strategy"] == n]
        parts.append(f"{n} {min(xs):.2f}–{max(xs):.2f}× the canonical time")
    diffs = sum(max(0, r["pixels_differing_from_canonical"]) for r in rows)
    verdict = (f"{component}: " + "; ".join(parts) + f" across {len(scenes)} scenes; "
               f"{diffs} pixels differ from the canonical images in all.")
    return {"status": "ok", "verdict": verdict, "tables": [C.md_table(header, trows)],
            "plots": [f"ablation_{component}.png"], "csv": ["results.csv"]}
