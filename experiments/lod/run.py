#!/usr/bin/python3
"""Level of detail (docs/lod.md): render time, steps per ray, memory and image error
against a whole-scene λ, and the exactness of the canonical traversal at each λ against
the brute-force oracle at the same λ.

Per scene and λ: `oblong render --lod λ` with the primary integrator at 1 spp (camera
rays; the shading normal of the micro-triangle as colour) and with the path tracer at
1 spp (secondary rays are where LoD is meant to pay); the image error of the primary
image against a reference rendered at full resolution (λ = 0) with 64 spp, i.e. the
supersampled, filtered truth a pixel should show: mean and max per-pixel error (mean
over RGB of |Δ|). Exactness: `oblong trace --lod λ` of a grid of camera rays with the
canonical configuration and with `--baseline bruteforce` at the same λ (λ > 0: level 0
is the conformance suites' job, and its brute force is the slow one); a mismatch
(hit/miss, or |Δt| > 1e-5·max(|t|, 1e-3)) fails the experiment. The per-ray rule
(`--lod cone --lod-bias b`, docs/lod.md) is rendered the same way and placed on the
error-against-time plot; its exactness is checked on primary renders (the pixel is the hit
micro-triangle's normal) against `--baseline bruteforce --lod cone` at the same per-ray λ:
any differing pixel fails the experiment.

    /usr/bin/python3 experiments/lod/run.py [--quick] [--build DIR] [--out DIR] [--reps N]
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "lib"))
import common as C  # noqa: E402
import rays as R  # noqa: E402

NAME = "lod"
TITLE = "Level of detail: time, steps, memory and image error against λ"
HYPOTHESIS = ("RMIP §2 / §5 Fig. 6 (fractional LoD) and TFDM: tracing a coarser, prefiltered level costs fewer "
              "steps and less time and memory, and under a camera that sees many texels per pixel a 1-spp image "
              "at a moderate λ is closer to the supersampled full-resolution image than the 1-spp full-resolution "
              "one (less aliasing), until λ removes detail the pixels do show; the traversal stays exact at every λ.")


FULL = {"ref_spp": 64, "size": "320x240", "small": "80x60"}  # the full run's (ctx.pick below)


def plot(rows: list, out, ref_spp: int = FULL["ref_spp"], wh: str = FULL["size"], swh: str = FULL["small"]) -> None:
    """lod.png from the rows of results.csv (also `run.py --replot`, with the full run's sizes)."""
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    plt = C.plt()
    fig, axes = plt.subplots(1, 4, figsize=(20, 4.4))
    for s in scenes:
        pts = [r for r in rows if r["scene"] == s and r["rule"] == "fixed"]
        cones = [r for r in rows if r["scene"] == s and r["rule"] == "cone"]
        t0 = pts[0]["primary_s_median"]
        axes[0].plot([r["primary_s_median"] / t0 for r in cones], [r["error_mean"] for r in cones], "*",
                     markersize=10, label=f"{C.short(s)}: cone (labels: bias)")
        for r in cones:
            axes[0].annotate(f"b{r['bias']:g}", (r["primary_s_median"] / t0, r["error_mean"]), fontsize=7,
                             xytext=(3, -9), textcoords="offset points")
        for r in cones:
            axes[3].axhline(r["error_mean"], linestyle=":", linewidth=0.8, alpha=0.6)
        axes[0].plot([r["primary_s_median"] / t0 for r in pts], [r["error_mean"] for r in pts], "o-",
                     label=f"{C.short(s)}: mean")
        axes[0].plot([r["primary_s_median"] / t0 for r in pts], [r["error_max"] for r in pts], "x--",
                     label=f"{C.short(s)}: max")
        for r in pts:
            axes[0].annotate(f"{r['lod']:g}", (r["primary_s_median"] / t0, r["error_mean"]), fontsize=7,
                             xytext=(3, 3), textcoords="offset points")
        axes[1].plot([r["lod"] for r in pts], [r["steps_per_camera_ray"] for r in pts], "o-",
                     label=f"{C.short(s)}: camera rays")
        axes[1].plot([r["lod"] for r in pts], [r["primary_s_median"] / t0 for r in pts], "s--",
                     label=f"{C.short(s)}: primary time / λ=0")
        axes[1].plot([r["lod"] for r in pts], [r["path_s_median"] / pts[0]["path_s_median"] for r in pts], "^:",
                     label=f"{C.short(s)}: path time / λ=0")
        axes[2].plot([r["lod"] for r in pts], [r["range_bytes"] / 2**20 for r in pts], "o-",
                     label=f"{C.short(s)}: range query")
        axes[2].plot([r["lod"] for r in pts], [r["total_bytes"] / 2**20 for r in pts], "s--",
                     label=f"{C.short(s)}: all structures")
        axes[3].plot([r["lod"] for r in pts], [r["error_mean"] for r in pts], "o-", label=f"{C.short(s)}: {wh}")
        axes[3].plot([r["lod"] for r in pts], [r["error_mean_small"] for r in pts], "s--",
                     label=f"{C.short(s)}: {swh} (16× texels per pixel)")
    axes[0].set_xlabel("primary render time / time at λ = 0 (1 thread, median)")
    # The metric: each pixel's mean absolute difference over RGB (L1), then the mean or max over pixels.
    axes[0].set_ylabel(f"per-pixel L1 error (mean over RGB of |img − ref|)\nvs {ref_spp}-spp λ=0 reference")
    axes[0].set_yscale("log")
    axes[0].set_title("image error against run time (labels: λ; stars: --lod cone)")
    axes[1].set_xlabel("λ")
    axes[1].set_ylabel("steps per camera ray; time ratio")
    axes[1].set_yscale("log")
    axes[1].set_title("work against λ")
    axes[2].set_xlabel("λ")
    axes[2].set_ylabel("MiB")
    axes[2].set_yscale("log")
    axes[2].set_title("memory against λ")
    axes[3].set_xlabel("λ")
    axes[3].set_ylabel(f"mean per-pixel L1 error (mean over RGB of |img − ref|)\nvs {ref_spp}-spp λ=0 reference")
    axes[3].set_yscale("log")
    axes[3].set_title(f"1-spp primary image error against λ, two image sizes\n(dotted: --lod cone at {wh}, one per bias)")
    for a in axes:
        a.grid(True, which="both", alpha=0.3)
        # "work against λ": its curves fall to the right, the lower left stays free.
        a.legend(fontsize=6.5, loc="lower left" if a is axes[1] else "best")
    fig.tight_layout()
    fig.savefig(out / "lod.png", bbox_inches="tight")


def run(ctx):
    import numpy as np

    scenes = ctx.pick(["paper/terracotta_roof", "paper/diving_helmet"], ["sphere"])
    lods = ctx.pick([0, 0.5, 1, 1.5, 2, 3, 4, 5, 6], [0, 1.5, 3])
    biases = ctx.pick([-2, -1, 0, 1], [0])  # --lod cone: a λ per ray from its ray cone, plus a bias
    size = ctx.pick(tuple(map(int, FULL["size"].split("x"))), (48, 36))
    small = ctx.pick(tuple(map(int, FULL["small"].split("x"))), (16, 12))  # the same view, 16x the texels per pixel
    check = ctx.pick((96, 72), (24, 18))
    ref_spp = ctx.pick(FULL["ref_spp"], 4)
    reps = ctx.reps(3, 1)
    wh = f"{size[0]}x{size[1]}"
    swh = f"{small[0]}x{small[1]}"
    jobs, setup, failures = [], {}, []
    for s in scenes:
        doc = C.load_scene(C.scene_path(s))
        ref_path = ctx.tmp(f"{C.short(s)}_ref.pfm")
        ref = C.run_oblong(ctx, "render", C.scene_path(s), ["--integrator", "primary", "--spp", ref_spp, "--size", wh,
                                                            "-o", ref_path], label=f"{s}/reference", threads=2)
        C.run_oblong(ctx, "render", C.scene_path(s), ["--integrator", "primary", "--spp", ref_spp, "--size", swh,
                                                      "-o", ctx.tmp(f"{C.short(s)}_ref_small.pfm")],
                     label=f"{s}/reference_small", threads=2)
        rays = R.camera_rays(doc, *check)
        rays_path = ctx.tmp(f"{C.short(s)}_check.bin")
        R.write_rays(rays_path, rays)
        exact = {}
        for lam in lods:
            exact[lam] = {"rays": 0, "oracle_hits": 0, "mismatches": 0}
            if lam > 0:  # level 0: the conformance suites' and error_vs_time's job (and the slowest oracle)
                for k, flags in (("canonical", []), ("bruteforce", ["--baseline", "bruteforce"])):
                    out = ctx.tmp(f"{C.short(s)}_{lam:g}_{k}.csv")
                    C.run_oblong(ctx, "trace", C.scene_path(s), flags + ["--lod", lam, "--rays", rays_path, "-o", out],
                                 label=f"{s}/trace/{k}", threads=2)
                exact[lam] = R.compare(R.read_hits(ctx.tmp(f"{C.short(s)}_{lam:g}_bruteforce.csv")),
                                       R.read_hits(ctx.tmp(f"{C.short(s)}_{lam:g}_canonical.csv")), rays)
                if exact[lam]["mismatches"]:
                    failures.append(f"{s} at lod {lam:g}: {exact[lam]['mismatches']} mismatches against the oracle")
            # Error only (deterministic; not timed): the small image.
            C.run_oblong(ctx, "render", C.scene_path(s), ["--lod", lam, "--integrator", "primary", "--size", swh,
                                                          "-o", ctx.tmp(f"{C.short(s)}_{lam:g}_small.pfm")],
                         label=f"{s}/small", threads=2)
            for integ in ("primary", "path"):
                jobs.append((f"{s}/{lam:g}/{integ}", "render", C.scene_path(s),
                             ["--lod", lam, "--integrator", integ, "--size", wh,
                              "-o", ctx.tmp(f"{C.short(s)}_{lam:g}_{integ}.pfm")]))
        # A λ per ray (--lod cone): `trace` takes rays without cones, so exactness is checked on
        # renders: the primary image's pixel is the hit micro-triangle's normal, and every pixel
        # of the canonical render must equal the brute force's at the same per-ray λ.
        for b in biases:
            imgs = {}
            for k, flags in (("canonical", []), ("bruteforce", ["--baseline", "bruteforce"])):
                out = ctx.tmp(f"{C.short(s)}_cone{b:g}_{k}_check.pfm")
                C.run_oblong(ctx, "render", C.scene_path(s), flags + ["--lod", "cone", "--lod-bias", b, "--integrator",
                                                                      "primary", "--size", f"{check[0]}x{check[1]}",
                                                                      "-o", out], label=f"{s}/cone/{k}", threads=2)
                imgs[k] = C.read_pfm(out)
            diff = int((np.abs(imgs["canonical"] - imgs["bruteforce"]).max(axis=2) > 0).sum())
            exact[f"cone{b:g}"] = {"rays": check[0] * check[1], "mismatches": diff}
            if diff:
                failures.append(f"{s} with --lod cone --lod-bias {b:g}: {diff} pixels differ from the oracle's")
            C.run_oblong(ctx, "render", C.scene_path(s), ["--lod", "cone", "--lod-bias", b, "--integrator", "primary",
                                                          "--size", swh, "-o", ctx.tmp(f"{C.short(s)}_cone{b:g}_small.pfm")],
                         label=f"{s}/small", threads=2)
            for integ in ("primary", "path"):
                jobs.append((f"{s}/cone{b:g}/{integ}", "render", C.scene_path(s),
                             ["--lod", "cone", "--lod-bias", b, "--integrator", integ, "--size", wh,
                              "-o", ctx.tmp(f"{C.short(s)}_cone{b:g}_{integ}.pfm")]))
        setup[s] = {"ref": C.read_pfm(ref_path), "ref_small": C.read_pfm(ctx.tmp(f"{C.short(s)}_ref_small.pfm")),
                    "ref_s": ref.seconds, "exact": exact, "map": C.map_size(doc)}
        ctx.log(f"{s}: reference {wh} at {ref_spp} spp in {ref.seconds:.1f} s (2 threads); oracle check "
                f"{check[0]}x{check[1]} rays at {len(lods) - 1} λ > 0: "
                f"{sum(e['mismatches'] for e in exact.values())} mismatches")
    ctx.log(f"{len(jobs)} renders x {reps} rounds")
    res = C.interleaved(ctx, jobs, reps)

    rows = []
    for s in scenes:
        su = setup[s]
        for lam in list(lods) + [f"cone{b:g}" for b in biases]:
            cone = isinstance(lam, str)
            key = lam if cone else f"{lam:g}"
            p, q = res[f"{s}/{key}/primary"], res[f"{s}/{key}/path"]
            img = C.read_pfm(ctx.tmp(f"{C.short(s)}_{key}_primary.pfm"))  # deterministic (same seed every round)
            err = np.abs(img - su["ref"]).mean(axis=2)
            err_small = np.abs(C.read_pfm(ctx.tmp(f"{C.short(s)}_{key}_small.pfm")) - su["ref_small"]).mean(axis=2)
            st, sq = p[0].stats, q[0].stats
            lod_used = st["config"]["lod"]
            per = [x for x in lod_used["per_mesh"] if x is not None] if isinstance(lod_used, dict) and \
                "per_mesh" in lod_used else [0.0]
            e = su["exact"][lam]
            rows.append({"scene": s, "lod": lam, "rule": "cone" if cone else "fixed",
                         "bias": float(lam[4:]) if cone else None,
                         "lod_traced": None if cone else (max(per) if per else 0.0),
                         "lod_camera_mean": st.get("lod_per_ray", {}).get("camera_mean"),
                         "lod_camera_at_0": st.get("lod_per_ray", {}).get("camera_at_0"),
                         "primary_s_median": C.med([r.seconds for r in p]), "primary_s_min": min(r.seconds for r in p),
                         "primary_s_max": max(r.seconds for r in p),
                         "path_s_median": C.med([r.seconds for r in q]), "path_s_min": min(r.seconds for r in q),
                         "path_s_max": max(r.seconds for r in q),
                         "steps_per_camera_ray": st["ray_counters"]["steps_per_ray"],
                         "steps_per_ray_path": sq["ray_counters"]["steps_per_ray"],
                         "range_bytes": C.range_bytes(st), "total_bytes": C.total_bytes(st),
                         "peak_bytes": int(st.get("peak_memory", 0)),
                         "error_mean": float(err.mean()), "error_max": float(err.max()),
                         "error_mean_small": float(err_small.mean()), "error_max_small": float(err_small.max()),
                         "oracle_rays": e["rays"], "oracle_hits": e.get("oracle_hits", ""), "mismatches": e["mismatches"],
                         "rounds": len(p)})
    C.write_csv(ctx.out / "results.csv", rows)

    plot(rows, ctx.out, ref_spp, wh, swh)


    header = ["scene", "λ", "primary s", "× λ=0", "path s", "× λ=0", "steps/camera ray", "range query",
              "mean error", "max error", f"mean error {swh}", "oracle mismatches"]
    trows = []
    def lod_label(r):
        if r["rule"] == "cone":
            return f"cone, bias {r['bias']:g} (camera rays: mean λ {r['lod_camera_mean']:.2f})"
        return f"{r['lod']:g}" + ("" if r["lod_traced"] == r["lod"] else f" (→{r['lod_traced']:g})")

    for s in scenes:
        pts = [r for r in rows if r["scene"] == s]
        for r in pts:
            trows.append([C.short(s), lod_label(r),
                          f"{r['primary_s_median']:.3f}", f"{r['primary_s_median'] / pts[0]['primary_s_median']:.2f}",
                          f"{r['path_s_median']:.3f}", f"{r['path_s_median'] / pts[0]['path_s_median']:.2f}",
                          f"{r['steps_per_camera_ray']:.2f}", C.fmt_bytes(r["range_bytes"]),
                          f"{r['error_mean']:.4f}", f"{r['error_max']:.3f}", f"{r['error_mean_small']:.4f}",
                          f"{r['mismatches']} / {r['oracle_rays']}" if r["oracle_rays"] else "–"])
    parts = []
    for s in scenes:
        pts = [r for r in rows if r["scene"] == s and r["rule"] == "fixed"]
        cones = [r for r in rows if r["scene"] == s and r["rule"] == "cone"]
        best = min(pts, key=lambda r: r["error_mean"])
        bsm = min(pts, key=lambda r: r["error_mean_small"])
        last = pts[-1]
        parts.append(f"{C.short(s)}: lowest mean error at λ={best['lod']:g} ({best['error_mean']:.4f} vs "
                     f"{pts[0]['error_mean']:.4f} at λ=0, time ×{best['primary_s_median'] / pts[0]['primary_s_median']:.2f}); "
                     f"at λ={last['lod']:g} steps/camera ray {pts[0]['steps_per_camera_ray']:.1f} → "
                     f"{last['steps_per_camera_ray']:.1f}, path time ×{last['path_s_median'] / pts[0]['path_s_median']:.2f}; "
                     f"at {swh}: lowest mean error at λ={bsm['lod']:g} ({bsm['error_mean_small']:.4f} vs "
                     f"{pts[0]['error_mean_small']:.4f} at λ=0)")
        for r in cones:
            parts.append(f"{C.short(s)} --lod cone, bias {r['bias']:g} (mean camera λ {r['lod_camera_mean']:.2f}): "
                         f"mean error {r['error_mean']:.4f} "
                         f"({r['error_mean_small']:.4f} at {swh}), primary time ×"
                         f"{r['primary_s_median'] / pts[0]['primary_s_median']:.2f}, path time ×"
                         f"{r['path_s_median'] / pts[0]['path_s_median']:.2f}, steps/camera ray "
                         f"{r['steps_per_camera_ray']:.2f}")
    verdict = "; ".join(parts) + "."
    if failures:
        return {"status": "mismatch", "verdict": "exactness at λ FAILED: " + "; ".join(failures),
                "tables": [C.md_table(header, trows)], "plots": ["lod.png"], "csv": ["results.csv"]}
    verdict += (" Canonical vs brute force at the same λ: 0 mismatches at every λ, and 0 differing pixels under "
                "--lod cone at every bias.")
    return {"status": "ok", "verdict": verdict, "tables": [C.md_table(header, trows)], "plots": ["lod.png"],
            "csv": ["results.csv"]}


if __name__ == "__main__":
    sys.exit(C.replot(sys.modules[__name__]) if "--replot" in sys.argv else C.main(sys.modules[__name__]))
