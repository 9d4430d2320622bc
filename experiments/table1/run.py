#!/usr/bin/python3
"""Table 1 of the RMIP paper on this CPU: per scene, TFDM (1x), pre-tessellation and the
canonical configuration at low / normal / high RMIP resolution; memory ratio and
render-time speed-up over TFDM, camera rays and path tracing, and trace-time speed-up on
grazing rays (bench_traversal's family: within 0.5-6 degrees of the base surface, aimed
into the shell; the paper has no such column).

    /usr/bin/python3 experiments/table1/run.py [--quick] [--build DIR] [--out DIR] [--reps N]
"""
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "lib"))
import common as C  # noqa: E402

NAME = "table1"
TITLE = "Table 1: memory and speed-up over TFDM (pre-tessellation, RMIP low / normal / high)"
HYPOTHESIS = ("RMIP paper §6, Table 1: at about TFDM's memory (the 'RMIP' column) the canonical traversal "
              "renders 5× faster than TFDM on average (standard deviation 3×, GPU path tracing); low-resolution "
              "RMIP reaches TFDM's speed or better with a small fraction of its memory; pre-tessellation is "
              "fastest but needs 10–235× the memory.")

# What C.TFDM runs, as a scene's strategies: the bytes "RMIP normal" is chosen against.
TFDM_STRATEGIES = {"baseline": {"name": "tfdm"}}
CONFIGS = ["tfdm", "tfdm_world", "driver_mipmap", "tessellated", "rmip_low", "rmip_normal", "rmip_high"]
LABELS = {"tfdm": "TFDM (1×)", "tfdm_world": C.TFDM_WORLD_LABEL, "driver_mipmap": C.DRIVER_MIPMAP_LABEL,
          "tessellated": "pre-tessellation",
          "rmip_low": "RMIP low", "rmip_normal": "RMIP normal", "rmip_high": "RMIP high"}


# The configurations compared with TFDM, in the plot's and the table's order.
COLS = ["tfdm_world", "driver_mipmap", "tessellated", "rmip_low", "rmip_normal", "rmip_high"]


def plot(rows: list, out) -> None:
    """table1.png from the rows of results.csv (also `run.py --replot`)."""
    names = list(dict.fromkeys(r["scene"] for r in rows))
    sizes = {r["integrator"]: r["size"] for r in rows}
    # Plot: speed-up over TFDM per scene (camera rays, path tracing) and memory ratio.
    plt = C.plt()
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    fig, axes = plt.subplots(1, 4, figsize=(16, 3.6))
    cols = COLS
    colors = {"tfdm_world": "tab:purple", "driver_mipmap": "tab:blue", "tessellated": "0.6", "rmip_low": "tab:green",
              "rmip_normal": "tab:orange", "rmip_high": "tab:red"}
    wbar = 0.13

    def row(sc, integ, cfg):
        return next(r for r in rows if r["scene"] == sc and r["integrator"] == integ and r["config"] == cfg)
    for ax, integ in zip(axes[:3], sizes):
        for i, cfg in enumerate(cols):
            xs, ys, lo, hi = [], [], [], []
            for j, sc in enumerate(names):
                r = row(sc, integ, cfg)
                if not r["fits"]:
                    continue
                xs.append(j + (i - 2.5) * wbar)
                ys.append(r["speedup_vs_tfdm_median"])
                lo.append(r["speedup_vs_tfdm_median"] - r["speedup_min"])
                hi.append(r["speedup_max"] - r["speedup_vs_tfdm_median"])
            ax.bar(xs, ys, wbar, yerr=[lo, hi], color=colors[cfg], label=LABELS[cfg], capsize=2)
        ax.axhline(1, color="k", lw=0.8)
        ax.set_yscale("log")
        # Numbered at 1, 2, 5 per decade: one labelled tick per panel does not read.
        ax.yaxis.set_major_locator(LogLocator(base=10, subs=(1, 2, 5)))
        ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"×{v:g}"))
        ax.yaxis.set_minor_formatter(NullFormatter())
        ax.set_xticks(range(len(names)), names, rotation=20, fontsize=7)
        ax.set_ylabel("speed-up over TFDM (median, range)")
        ax.set_title(f"{integ} ({sizes[integ]}, 1 thread)" if integ == "grazing"
                     else f"{integ} ({sizes[integ]}, 1 spp, 1 thread)")
        ax.grid(True, axis="y", which="both", alpha=0.3)
    ax = axes[3]
    for i, cfg in enumerate(cols):
        pts = [(j + (i - 2.5) * wbar, row(sc, "primary", cfg)) for j, sc in enumerate(names)]
        pts = [(x, r) for x, r in pts if r["fits"]]
        ax.bar([x for x, _ in pts], [r["mem_ratio_vs_tfdm"] for _, r in pts], wbar, color=colors[cfg],
               label=LABELS[cfg])
    ax.axhline(1, color="k", lw=0.8)
    ax.set_yscale("log")
    ax.set_xticks(range(len(names)), names, rotation=20, fontsize=7)
    ax.set_ylabel("data-structure memory / TFDM's mipmap")
    ax.set_title("memory (lower is better)")
    ax.grid(True, axis="y", which="both", alpha=0.3)
    # One legend for the three panels, below them, where it hides no bar.
    # Patches by hand: a configuration that fits no scene has an empty bar set, whose handle has no colour.
    from matplotlib.patches import Patch
    handles = [Patch(color=colors[c], label=LABELS[c]) for c in cols]
    fig.legend(handles=handles, loc="lower center", ncol=len(cols), fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    fig.savefig(out / "table1.png", bbox_inches="tight")


def grazing_rays(ctx, scene: str, n: int) -> Path:
    """bench_traversal's grazing family on the scene, as a ray file for `oblong trace`."""
    out = ctx.tmp(f"{C.short(scene)}_grazing.bin")
    bench = ctx.binary.parent / "bench_traversal"
    if not bench.exists():
        raise C.ExperimentError(f"{bench} missing (the benchmarks' build: cmake --build "
                                f"{ctx.binary.parent} --target bench_traversal)")
    subprocess.run([str(bench), "--scene", str(C.scene_path(scene)), "--grazing", str(n), "--write-grazing",
                    str(out)], check=True, cwd=C.ROOT, capture_output=True, timeout=600)
    return out


def run(ctx):
    scenes = ctx.pick(C.PAPER_SCENES, ["paper/terracotta_roof"])
    n_grazing = ctx.pick(20000, 500)
    sizes = {"primary": ctx.pick("256x192", "32x24"), "path": ctx.pick("128x96", "16x12"),
             "grazing": f"{n_grazing} rays"}
    reps = ctx.reps(3, 1)
    jobs = []
    meta, tess = {}, {}
    grazing = {}
    for s in scenes:
        doc = C.load_scene(C.scene_path(s))
        w, h = C.map_size(doc)
        tess[s] = C.tessellation_fit(ctx, C.scene_path(s))
        grazing[s] = grazing_rays(ctx, s, n_grazing)
        for cfg in CONFIGS:
            if cfg.startswith("rmip_"):
                level = cfg[5:]
                if level == "normal":  # the paper's "RMIP" column: about TFDM's memory
                    res, div, _ = C.rmip_nearest_resolution(ctx, s, C.structure_bytes(ctx, s, TFDM_STRATEGIES))
                else:
                    res, div = C.rmip_resolution(doc, level), C.RMIP_LEVELS[level]
                scene = ctx.scene_variant(s, f"{C.short(s)}_rmip{res}",
                                          strategies={"range": {"name": "rmip", "resolution": res}})
                args = list(C.CANONICAL)
                meta[(s, cfg)] = f"resolution {res} (map {w}×{h} / {div})"
            elif cfg == "tfdm_world":
                scene = ctx.scene_variant(s, f"{C.short(s)}_tfdm_world", strategies=C.TFDM_WORLD_STRATEGIES)
                args = []
                meta[(s, cfg)] = ""
            else:
                # Pre-tessellating a paper-scale map takes 20-30 s per run: not in quick mode.
                if cfg == "tessellated" and (ctx.quick or not tess[s]["fits"]):
                    continue
                scene = C.scene_path(s)
                args = {"tfdm": C.TFDM, "driver_mipmap": C.DRIVER_MIPMAP,
                        "tessellated": ["--baseline", "tessellated"]}[cfg]
                args = list(args)
                meta[(s, cfg)] = ""
            for integ, size in sizes.items():
                if integ == "grazing":  # the same rays for every configuration (the base geometry's)
                    jobs.append(((s, cfg, integ), "trace", scene,
                                 args + ["--rays", grazing[s], "-o", ctx.tmp("grazing_hits.bin"), "-q"]))
                else:
                    jobs.append(((s, cfg, integ), "render", scene, args + ["--integrator", integ, "--size", size]))
    ctx.log(f"{len(jobs)} configurations x {reps} rounds")
    res = C.interleaved(ctx, [("|".join(k), sub, sc, a) for k, sub, sc, a in jobs], reps)
    runs = {tuple(k.split("|")): v for k, v in res.items()}

    rows = []
    for s in scenes:
        for integ in sizes:
            base = runs[(s, "tfdm", integ)]
            b0 = base[0].stats
            for cfg in CONFIGS:
                if (s, cfg, integ) not in runs:
                    t = tess[s]
                    why = ("not run (quick mode)" if t["fits"] else
                           f"does not fit: {t['micro_triangles']} micro-triangles, {t['needs']}")
                    rows.append({"scene": C.short(s), "integrator": integ, "size": sizes[integ], "config": cfg,
                                 "geometry": why,
                                 "range_bytes": t["needs_bytes"], "fits": False})
                    continue
                rs = runs[(s, cfg, integ)]
                st = rs[0].stats
                sp = C.paired_ratios(base, rs)
                lo, hi = C.spread(sp)
                secs = [r.seconds for r in rs]
                rays = st["rays"]["count"] if integ == "grazing" else st["rays"]["primary"] + st["rays"]["secondary"]
                rows.append({
                    "scene": C.short(s), "integrator": integ, "size": sizes[integ], "config": cfg, "fits": True,
                    "geometry": st["geometry"], "rmip": meta[(s, cfg)],
                    "render_s_median": C.med(secs), "render_s_min": min(secs), "render_s_max": max(secs),
                    "speedup_vs_tfdm_median": C.med(sp), "speedup_min": lo, "speedup_max": hi,
                    "range_bytes": C.range_bytes(st), "total_bytes": C.total_bytes(st),
                    "mem_ratio_vs_tfdm": C.range_bytes(st) / max(1, C.range_bytes(b0)),
                    "total_mem_ratio_vs_tfdm": C.total_bytes(st) / max(1, C.total_bytes(b0)),
                    "build_s_median": C.med([r.build_seconds for r in rs]),
                    "rays": rays, "mrays_per_s_median": rays / C.med(secs) * 1e-6,
                    "steps_per_ray": st["ray_counters"]["steps_per_ray"],
                    "steps_ratio_tfdm_over_this": (b0["ray_counters"]["steps_per_ray"]
                                                   / max(1e-9, st["ray_counters"]["steps_per_ray"])),
                    "process_cpu_s_median": C.med([r.cpu for r in rs]),
                    "rounds": len(rs),
                })
    C.write_csv(ctx.out / "results.csv", rows)
    names = [C.short(s) for s in scenes]

    plot(rows, ctx.out)
    cols = COLS

    # Markdown: the paper's layout, one row per scene and integrator.
    header = (["scene", "rays", "TFDM mem", "TFDM time", "TFDM steps/ray"]
              + [f"{LABELS[c]} mem / speed-up" for c in cols] + ["canonical (RMIP high) steps/ray"])
    trows = []
    for sc in names:
        for integ in sizes:
            g = {r["config"]: r for r in rows if r["scene"] == sc and r["integrator"] == integ}
            t = g["tfdm"]
            cells = [sc, integ, C.fmt_bytes(t["range_bytes"]), f"{t['render_s_median']:.3f} s",
                     f"{t['steps_per_ray']:.1f}"]
            for c in cols:
                r = g[c]
                if not r["fits"]:
                    cells.append(r["geometry"])
                    continue
                cells.append(f"{C.fmt_ratio(r['mem_ratio_vs_tfdm'], digits=3 if r['mem_ratio_vs_tfdm'] < 0.1 else 2)}"
                             f" / {C.fmt_ratio(r['speedup_vs_tfdm_median'], r['speedup_min'], r['speedup_max'])}")
            cells.append(f"{g['rmip_high']['steps_per_ray']:.1f} (TFDM ×{g['rmip_high']['steps_ratio_tfdm_over_this']:.1f})")
            trows.append(cells)
    table = C.md_table(header, trows)
    res_rows = [[C.short(s)] + [meta[(s, c)] for c in ("rmip_low", "rmip_normal", "rmip_high")]
                + [f"{tess[s]['micro_triangles']} micro-triangles, {tess[s]['needs']}"
                   + ("" if tess[s]["fits"] else " (does not fit)")] for s in scenes]
    restable = C.md_table(["scene", "RMIP low", "RMIP normal", "RMIP high", "pre-tessellation"], res_rows)

    def stats(cfg, integ):
        xs = [r["speedup_vs_tfdm_median"] for r in rows if r["config"] == cfg and r["integrator"] == integ
              and r["fits"]]
        if not xs:
            return float("nan"), float("nan"), float("nan")
        m = sum(xs) / len(xs)
        sd = (sum((x - m) ** 2 for x in xs) / max(1, len(xs) - 1)) ** 0.5
        return m, sd, C.geomean(xs)

    num = {}
    for cfg in cols:
        for integ in sizes:
            m, sd, g = stats(cfg, integ)
            num[f"mean_speedup_{cfg}_{integ}"] = m
            num[f"sd_speedup_{cfg}_{integ}"] = sd
            num[f"geomean_speedup_{cfg}_{integ}"] = g
    num["geomean_steps_ratio_high"] = C.geomean([r["steps_ratio_tfdm_over_this"] for r in rows
                                                 if r["config"] == "rmip_high" and r["integrator"] == "primary"])
    memn = [r["mem_ratio_vs_tfdm"] for r in rows if r["config"] == "rmip_normal" and r["integrator"] == "path"]
    meml = [r["mem_ratio_vs_tfdm"] for r in rows if r["config"] == "rmip_low" and r["integrator"] == "path"]
    verdict = (f"RMIP normal (memory ×{min(memn):.2f}–{max(memn):.2f} of TFDM's mipmap): speed-up over TFDM "
               f"mean ×{num['mean_speedup_rmip_normal_path']:.2f} (sd {num['sd_speedup_rmip_normal_path']:.2f}, "
               f"geomean ×{num['geomean_speedup_rmip_normal_path']:.2f}) path-traced, mean "
               f"×{num['mean_speedup_rmip_normal_primary']:.2f} (geomean "
               f"×{num['geomean_speedup_rmip_normal_primary']:.2f}) camera rays, mean "
               f"×{num['mean_speedup_rmip_normal_grazing']:.2f} (geomean "
               f"×{num['geomean_speedup_rmip_normal_grazing']:.2f}) grazing rays, against the paper's ×5 (sd 3) on "
               f"GPU; RMIP low (memory ×{min(meml):.3f}–{max(meml):.3f}) ×{num['geomean_speedup_rmip_low_path']:.2f},"
               f" RMIP high ×{num['geomean_speedup_rmip_high_path']:.2f} (geomeans, path); "
               f"{C.TFDM_WORLD_LABEL} ×{num['geomean_speedup_tfdm_world_path']:.2f} (path) / "
               f"×{num['geomean_speedup_tfdm_world_primary']:.2f} (camera); "
               f"{C.DRIVER_MIPMAP_LABEL} ×{num['geomean_speedup_driver_mipmap_path']:.2f} (path) / "
               f"×{num['geomean_speedup_driver_mipmap_primary']:.2f} (camera); TFDM takes "
               f"×{num['geomean_steps_ratio_high']:.1f} the steps per camera ray of RMIP high (geomean).")
    return {"status": "ok", "verdict": verdict, "tables": [table, restable], "plots": ["table1.png"],
            "csv": ["results.csv"], "numbers": num}


if __name__ == "__main__":
    sys.exit(C.replot(sys.modules[__name__]) if "--replot" in sys.argv else C.main(sys.modules[__name__]))
