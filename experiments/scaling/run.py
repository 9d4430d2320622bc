#!/usr/bin/python3
"""Fig. 11 of the RMIP paper: speed-up of the canonical configuration (RMIP at about
TFDM's memory) over TFDM as the displacement scale and the tiling grow beyond the
scene's own. Variant scenes (scale, tiling) are written to the scratch folder and
recorded in run.json.

    /usr/bin/python3 experiments/scaling/run.py [--quick] [--build DIR] [--out DIR] [--reps N]
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "lib"))
import common as C  # noqa: E402

NAME = "scaling"
TITLE = "Fig. 11: speed-up over TFDM as displacement scale and tiling grow"
HYPOTHESIS = ("RMIP paper §6, Fig. 11: the speed-up over TFDM (equal memory) grows as the displacement magnitude "
              "or the tiling grows beyond the scene's own, confirming RMIP's better asymptotic traversal "
              "complexity.")


def run(ctx):
    # (series name, base scene, parameter, values, what the base scene has)
    series = ctx.pick(
        [("alien_sphere: displacement scale", "paper/alien_sphere", "scale", [0.5, 1, 2, 4, 8]),
         ("alien_sphere: tiling", "paper/alien_sphere", "tiling", [2, 8, 25, 50, 100]),
         ("terracotta_roof: tiling", "paper/terracotta_roof", "tiling", [1, 2, 8, 25, 100])],
        [("terracotta_roof: displacement scale", "paper/terracotta_roof", "scale", [1, 4]),
         ("terracotta_roof: tiling", "paper/terracotta_roof", "tiling", [2, 25])])
    integ = "path"
    size = ctx.pick("200x150", "16x12")
    reps = ctx.reps(3, 1)
    jobs, info = [], {}
    for name, base, param, values in series:
        doc = C.load_scene(C.scene_path(base))
        disp = next(m["displacement"] for m in doc["meshes"] if "displacement" in m)
        res = C.rmip_resolution(doc, "normal")
        for v in values:
            if param == "scale":
                over = {"scale": disp["scale"] * v}
                shown = f"scale {disp['scale'] * v:g} (×{v:g})"
            else:
                over = {"tiling": [v, v]}
                shown = f"tiling {v}×{v}"
            tag = f"{base}_{param}{v:g}"
            rm = ctx.scene_variant(base, f"{tag}_rmip{res}", displacement=over,
                                   strategies={"range": {"name": "rmip", "resolution": res}})
            tf = ctx.scene_variant(base, tag, displacement=over)
            info[(name, v)] = shown
            common = ["--integrator", integ, "--size", size]
            jobs.append((f"{name}|{v}|rmip_normal", "render", rm, C.CANONICAL + common))
            jobs.append((f"{name}|{v}|tfdm", "render", tf, C.TFDM + common))
    ctx.log(f"{len(jobs)} configurations x {reps} rounds")
    res = C.interleaved(ctx, jobs, reps)

    rows = []
    for name, base, param, values in series:
        for v in values:
            a, b = res[f"{name}|{v}|rmip_normal"], res[f"{name}|{v}|tfdm"]
            sp = C.paired_ratios(b, a)
            rows.append({"series": name, "scene": base, "parameter": param, "value": v, "variant": info[(name, v)],
                         "speedup_median": C.med(sp), "speedup_min": min(sp), "speedup_max": max(sp),
                         "rmip_render_s_median": C.med([r.seconds for r in a]),
                         "tfdm_render_s_median": C.med([r.seconds for r in b]),
                         "rmip_steps_per_ray": a[0].stats["ray_counters"]["steps_per_ray"],
                         "tfdm_steps_per_ray": b[0].stats["ray_counters"]["steps_per_ray"],
                         "rmip_range_bytes": C.range_bytes(a[0].stats), "tfdm_range_bytes": C.range_bytes(b[0].stats),
                         "mem_ratio": C.range_bytes(a[0].stats) / max(1, C.range_bytes(b[0].stats)),
                         "rmip_geometry": a[0].stats["geometry"], "rounds": len(sp)})
    C.write_csv(ctx.out / "results.csv", rows)

    plt = C.plt()
    fig, axes = plt.subplots(1, len(series), figsize=(4.2 * len(series), 3.5), squeeze=False)
    for ax, (name, base, param, values) in zip(axes[0], series):
        pts = [r for r in rows if r["series"] == name]
        ys = [r["speedup_median"] for r in pts]
        err = [[r["speedup_median"] - r["speedup_min"] for r in pts], [r["speedup_max"] - r["speedup_median"]
                                                                       for r in pts]]
        ax.errorbar(values, ys, yerr=err, marker="o", capsize=2, color="tab:orange", label="speed-up (time)")
        ax.plot(values, [r["tfdm_steps_per_ray"] / r["rmip_steps_per_ray"] for r in pts], "s--", ms=3,
                color="tab:blue", label="TFDM steps / RMIP steps")
        ax.axhline(1, color="k", lw=0.8)
        ax.set_xscale("log", base=2)
        ax.set_xlabel("displacement scale (× the scene's)" if param == "scale" else "tiling (per axis)")
        ax.set_ylabel("RMIP normal over TFDM")
        ax.set_title(f"{name} ({integ} {size}, 1 thread)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(ctx.out / "scaling.png")

    header = ["series", "variant", "speed-up (median, range)", "TFDM / RMIP steps", "RMIP time", "TFDM time",
              "memory RMIP / mipmap"]
    trows = [[r["series"], r["variant"], C.fmt_ratio(r["speedup_median"], r["speedup_min"], r["speedup_max"]),
              f"×{r['tfdm_steps_per_ray'] / r['rmip_steps_per_ray']:.2f}", f"{r['rmip_render_s_median']:.3f} s",
              f"{r['tfdm_render_s_median']:.3f} s", f"×{r['mem_ratio']:.2f}"] for r in rows]
    parts = []
    for name, base, param, values in series:
        pts = [r for r in rows if r["series"] == name]
        parts.append(f"{name}: ×{pts[0]['speedup_median']:.2f} → ×{pts[-1]['speedup_median']:.2f} "
                     f"({pts[0]['variant']} → {pts[-1]['variant']})")
    return {"status": "ok", "verdict": "Speed-up over TFDM " + "; ".join(parts) + ".",
            "tables": [C.md_table(header, trows)], "plots": ["scaling.png"], "csv": ["results.csv"]}


if __name__ == "__main__":
    sys.exit(C.main(sys.modules[__name__]))
