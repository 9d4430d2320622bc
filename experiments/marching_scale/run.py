#!/usr/bin/python3
"""Fig. 10 of the RMIP paper: render time against the texel-marching scale, for several
RMIP resolutions and for a minmax mipmap inside the RMIP traversal; TFDM (which has no
marching scale of its own: it runs at 1) as a flat reference.

    /usr/bin/python3 experiments/marching_scale/run.py [--quick] [--build DIR] [--out DIR] [--reps N]
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "lib"))
import common as C  # noqa: E402

NAME = "marching_scale"
TITLE = "Fig. 10: render time against marching scale, per RMIP resolution and for a minmax mipmap"
HYPOTHESIS = ("RMIP paper §6, Fig. 10: for every RMIP resolution there is a marching-scale sweet spot (too small: "
              "query/texel misalignment and the limited RMIP resolution are not amortised; too large: little "
              "hierarchical acceleration); at equal memory, a minmax mipmap inside the same traversal is slower "
              "than RMIP; all of them beat TFDM.")

CURVES = {"rmip_low": "RMIP low", "rmip_normal": "RMIP normal", "rmip_high": "RMIP high",
          "minmax": "minmax mipmap in the RMIP traversal"}


FULL_SIZE = "320x240"


def plot(rows: list, out) -> None:
    """marching_scale.png from the rows of results.csv (also `run.py --replot`)."""
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    curves = [cv for cv in CURVES if any(r["curve"] == cv for r in rows)]
    # results.csv of runs before the size column: the committed full run's size.
    size = rows[0].get("size") or FULL_SIZE
    best = {(s, cv): min((r for r in rows if r["scene"] == s and r["curve"] == cv),
                         key=lambda r: r["relative_time_median"]) for s in scenes for cv in curves}
    plt = C.plt()
    fig, axes = plt.subplots(2, len(scenes), figsize=(5.5 * len(scenes), 7), squeeze=False)
    colors = {"rmip_low": "tab:green", "rmip_normal": "gold", "rmip_high": "tab:red", "minmax": "tab:blue"}
    for j, s in enumerate(scenes):
        ax = axes[0][j]
        for cv in curves:
            pts = [r for r in rows if r["scene"] == s and r["curve"] == cv]
            xs = [r["marching_scale"] for r in pts]
            ys = [r["relative_time_median"] for r in pts]
            err = [[r["relative_time_median"] - r["relative_min"] for r in pts],
                   [r["relative_max"] - r["relative_time_median"] for r in pts]]
            lab = f"{CURVES[cv]} (mem ×{pts[0]['mem_vs_minmax_mipmap']:.2g})"
            ax.errorbar(xs, ys, yerr=err, marker="o", ms=3, color=colors[cv], label=lab, capsize=2)
            b = best[(s, cv)]
            ax.plot([b["marching_scale"]], [b["relative_time_median"]], "o", ms=9, mfc="none", mec="k", mew=1.5)
            axes[1][j].plot(xs, [r["boxes_per_ray"] for r in pts], "s--", ms=3, color=colors[cv])
            axes[1][j].plot(xs, [r["cells_per_ray"] for r in pts], "o-", ms=3, color=colors[cv], label=CURVES[cv])
        t = next(r for r in rows if r["scene"] == s and r["curve"] == "tfdm")
        ax.axhline(t["relative_time_median"], color="k", ls="--", lw=1, label="TFDM (mem ×1)")
        axes[1][j].axhline(t["boxes_per_ray"], color="k", ls="--", lw=0.8, label="TFDM boxes (dashed) / cells")
        axes[1][j].axhline(t["cells_per_ray"], color="k", ls="-", lw=0.8)
        for a in (ax, axes[1][j]):
            a.set_xscale("log", base=2)
            a.set_xlabel("marching scale (texels)")
            a.grid(True, which="both", alpha=0.3)
        ax.set_ylabel("render time / best RMIP-normal time")
        ax.set_title(f"{s}: camera rays {size}, 1 thread\n(median and range over rounds; circle = best)")
        ax.legend(fontsize=6.5)
        axes[1][j].set_yscale("log")
        axes[1][j].set_ylabel("per camera ray: boxes (dashed), cells marched (solid)")
        axes[1][j].set_title(f"{s}: work per ray (exact counts)")
        # Below the panel: inside, it covers the TFDM lines.
        axes[1][j].legend(fontsize=6.5, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3, frameon=False)
    fig.tight_layout()
    fig.savefig(out / "marching_scale.png", bbox_inches="tight")


def run(ctx):
    scenes = ctx.pick(["paper/terracotta_roof", "paper/diving_helmet"], ["paper/terracotta_roof"])
    scales = ctx.pick([1, 2, 4, 8, 16, 32], [1, 4, 16])
    curves = ctx.pick(list(CURVES), ["rmip_normal", "minmax"])
    size = ctx.pick(FULL_SIZE, "32x24")
    reps = ctx.reps(3, 1)
    jobs, desc = [], {}
    for s in scenes:
        doc = C.load_scene(C.scene_path(s))
        for cv in curves:
            if cv == "minmax":
                scene, flags = C.scene_path(s), ["--range", "minmax_mipmap"]
                desc[(s, cv)] = "minmax_mipmap + newton + midpoint2d, inversion on"
            else:
                res = C.rmip_resolution(doc, cv[5:])
                scene = ctx.scene_variant(s, f"{s}_rmip{res}", strategies={"range": {"name": "rmip",
                                                                                     "resolution": res}})
                flags = []
                desc[(s, cv)] = f"rmip resolution {res}"
            for k in scales:
                jobs.append((f"{s}/{cv}/{k}", "render", scene,
                             flags + ["--marching-scale", k, "--integrator", "primary", "--size", size]))
        jobs.append((f"{s}/tfdm/1", "render", C.scene_path(s), C.TFDM + ["--integrator", "primary", "--size", size]))
    ctx.log(f"{len(jobs)} configurations x {reps} rounds")
    res = C.interleaved(ctx, jobs, reps)

    rows = []
    best = {}
    for s in scenes:
        # Per round: time relative to the fastest RMIP-normal (or the first curve's) point of that round.
        ref_curve = "rmip_normal" if "rmip_normal" in curves else curves[0]
        nrounds = len(res[f"{s}/tfdm/1"])
        ref = [min(res[f"{s}/{ref_curve}/{k}"][r].seconds for k in scales) for r in range(nrounds)]
        tfdm_bytes = C.range_bytes(res[f"{s}/tfdm/1"][0].stats)
        for cv in curves + ["tfdm"]:
            for k in (scales if cv != "tfdm" else [1]):
                rs = res[f"{s}/{cv}/{k}"]
                rel = [r.seconds / ref[i] for i, r in enumerate(rs)]
                st = rs[0].stats
                rows.append({"scene": s, "curve": cv, "marching_scale": k, "range": desc.get((s, cv), "TFDM"),
                             "render_s_median": C.med([r.seconds for r in rs]),
                             "render_s_min": min(r.seconds for r in rs), "render_s_max": max(r.seconds for r in rs),
                             "relative_time_median": C.med(rel), "relative_min": min(rel), "relative_max": max(rel),
                             "steps_per_ray": st["ray_counters"]["steps_per_ray"],
                             "boxes_per_ray": st["ray_counters"]["boxes"] / st["rays"]["primary"],
                             "cells_per_ray": st["ray_counters"]["cells_marched"] / st["rays"]["primary"],
                             "range_bytes": C.range_bytes(st),
                             "mem_vs_minmax_mipmap": C.range_bytes(st) / max(1, tfdm_bytes), "rounds": len(rs),
                             "size": size})
            if cv != "tfdm":
                pts = [r for r in rows if r["scene"] == s and r["curve"] == cv]
                best[(s, cv)] = min(pts, key=lambda r: r["relative_time_median"])
    C.write_csv(ctx.out / "results.csv", rows)

    plot(rows, ctx.out)


    header = (["scene", "curve", "memory vs TFDM"] + [f"scale {k}" for k in scales]
              + ["best scale", "steps/camera ray at best"])
    trows = []
    for s in scenes:
        for cv in curves:
            pts = {r["marching_scale"]: r for r in rows if r["scene"] == s and r["curve"] == cv}
            trows.append([s, CURVES[cv], f"×{pts[scales[0]]['mem_vs_minmax_mipmap']:.2g}"] +
                         [f"{pts[k]['relative_time_median']:.2f}" for k in scales] +
                         [str(best[(s, cv)]["marching_scale"]), f"{best[(s, cv)]['steps_per_ray']:.1f}"])
        t = next(r for r in rows if r["scene"] == s and r["curve"] == "tfdm")
        trows.append([s, "TFDM (`tfdm`, no marching)", "×1"] + [f"{t['relative_time_median']:.2f}"]
                     + [""] * (len(scales) - 1) + ["–", f"{t['steps_per_ray']:.1f}"])
    parts = []
    for s in scenes:
        bs = ", ".join(f"{CURVES[cv]} {best[(s, cv)]['marching_scale']}" for cv in curves)
        t = next(r for r in rows if r["scene"] == s and r["curve"] == "tfdm")
        parts.append(f"{s}: best scales {bs}; TFDM at {t['relative_time_median']:.2f}× the best RMIP-normal time")
    verdict = "; ".join(parts) + "."
    return {"status": "ok", "verdict": verdict, "tables": [C.md_table(header, trows)],
            "plots": ["marching_scale.png"], "csv": ["results.csv"]}


if __name__ == "__main__":
    sys.exit(C.replot(sys.modules[__name__]) if "--replot" in sys.argv else C.main(sys.modules[__name__]))
