#!/usr/bin/python3
"""The methods side by side at equal time: the canonical configuration (RMIP traversal),
TFDM (`--baseline tfdm`), pre-tessellation (`--baseline tessellated`) and fixed-step
marching (`--baseline fixedstep`), path traced on one scene with the same time budget
each, with their error images against a high-spp reference: one PNG figure.

    /usr/bin/python3 experiments/methods_figure/run.py [--quick] [--build DIR] [--out DIR]

Equal time: a pilot render of every method at a few spp measures its seconds per spp
(`--stats` render time, `--threads 1`); each method then gets the canonical
configuration's time at BUDGET_SPP spp, i.e. spp = round(budget / its seconds per spp)
(at least 1). The panels give the spp and the time each final render took. The errors
come from `oblong compare` (relMSE, PSNR and the per-pixel error image).
"""
import json
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "lib"))
import common as C  # noqa: E402

NAME = "methods_figure"
TITLE = "The methods side by side at equal time, with error images"
HYPOTHESIS = ("At the same render time, the exact traversals (canonical RMIP, TFDM, pre-tessellation) differ only "
              "in noise, so the fastest has the lowest error; fixed-step marching adds a bias (missed or shifted "
              "detail) that more samples do not remove.")

METHODS = [("canonical", "canonical (RMIP)", C.CANONICAL),
           ("tfdm", "TFDM", C.TFDM),
           ("tessellated", "pre-tessellated", ["--baseline", "tessellated"]),
           ("fixedstep", "fixed step (1 texel)", ["--baseline", "fixedstep"])]


def compare(ctx, image: Path, reference: Path, error: Path) -> dict:
    p = subprocess.run([str(ctx.binary), "compare", str(image), str(reference), "-o", str(error), "--json"],
                       capture_output=True, text=True, timeout=120)
    if p.returncode != 0:
        raise C.ExperimentError(f"oblong compare {image} {reference}: {p.stderr.strip()}")
    return json.loads(p.stdout)


def run(ctx):
    import numpy as np

    scene_name = "terrain"
    scene = C.scene_path(scene_name)
    size = ctx.pick("240x180", "64x48")
    ref_spp = ctx.pick(512, 32)
    pilot_spp = ctx.pick(4, 1)
    budget_spp = ctx.pick(16, 2)  # the canonical configuration's spp: the time budget
    fit = C.tessellation_fit(ctx, scene)
    if not fit["fits"]:
        raise C.ExperimentError(f"{scene_name}: pre-tessellation needs {fit['needs']}: does not fit")

    # Reference: canonical, many samples, all cores (not timed), its own seed.
    ref = ctx.tmp("reference.pfm")
    r = C.run_oblong(ctx, "render", scene, ["--size", size, "--spp", ref_spp, "--seed", 12345, "-o", ref],
                     label="reference", threads=0)
    ctx.log(f"reference: {size} at {ref_spp} spp in {r.seconds:.1f} s")

    # Pilot: seconds per spp of each method, interleaved (the minimum of the rounds).
    jobs = [(key, "render", scene, ["--size", size, "--spp", pilot_spp, "-o", ctx.tmp(f"pilot_{key}.pfm")] + flags)
            for key, _, flags in METHODS]
    pilot = C.interleaved(ctx, jobs, ctx.reps(2, 1))
    per_spp = {key: min(x.seconds for x in pilot[key]) / pilot_spp for key, _, _ in METHODS}
    budget = per_spp["canonical"] * budget_spp
    spp = {key: max(1, round(budget / per_spp[key])) for key, _, _ in METHODS}
    ctx.log("seconds per spp: " + ", ".join(f"{k} {v:.3f}" for k, v in per_spp.items()) +
            f"; budget {budget:.2f} s; spp " + ", ".join(f"{k} {v}" for k, v in spp.items()))

    # The final renders, interleaved too: the time a panel gives is the median over the rounds
    # (the image is the same in every round: the same seed).
    final = C.interleaved(ctx, [(key, "render", scene, ["--size", size, "--spp", spp[key], "-o",
                                                        ctx.tmp(f"{key}.pfm")] + flags)
                                for key, _, flags in METHODS], ctx.reps(2, 1), seed=2)
    rows, images, errors = [], {}, {}
    for key, label, flags in METHODS:
        img = ctx.tmp(f"{key}.pfm")
        run_ = final[key][0]
        err = ctx.tmp(f"{key}_error.pfm")
        c = compare(ctx, img, ref, err)
        images[key] = C.read_pfm(img)
        errors[key] = C.read_pfm(err)[:, :, 0]
        rows.append({"method": key, "label": label, "spp": spp[key], "seconds_per_spp_pilot": per_spp[key],
                     "seconds": C.med([x.seconds for x in final[key]]),
                     "seconds_min": min(x.seconds for x in final[key]),
                     "seconds_max": max(x.seconds for x in final[key]), "budget_s": budget, "relmse": c["relmse"], "mse": c["mse"],
                     "psnr_db": c["psnr_db"] if isinstance(c["psnr_db"], float) else float("inf"),
                     "steps_per_camera_ray": run_.stats["steps_per_camera_ray"],
                     "memory_bytes": C.total_bytes(run_.stats)})
    C.write_csv(ctx.out / "results.csv", rows)

    # The figure: renders on top, error images below on one shared log scale.
    plt = C.plt()
    from matplotlib.colors import LogNorm

    w, h = map(int, size.split("x"))
    n = len(METHODS) + 1
    # Sizes in inches: the figure's height follows the images' so that the rows sit close.
    width = 2.4 * n + 0.7
    left, right, top, bottom, hspace, wspace = 0.01, 0.94, 0.82, 0.01, 0.3, 0.05
    img_w = width * (right - left) / (n + 0.06 + wspace * n)
    img_h = img_w * h / w
    fig = plt.figure(figsize=(width, img_h * (2 + hspace) / (top - bottom)))
    # One column more for the error images' colour bar, so every image has the same size.
    gs = fig.add_gridspec(2, n + 1, width_ratios=[1] * n + [0.06], hspace=hspace, wspace=wspace, left=left,
                          right=right, top=top, bottom=bottom)
    axes = np.array([[fig.add_subplot(gs[i, j]) for j in range(n)] for i in range(2)])
    cax = fig.add_subplot(gs[1, n])

    def show(img):
        return np.clip(img, 0, 1) ** (1 / 2.2)  # linear to display (sRGB-like gamma)
    all_err = np.concatenate([e.ravel() for e in errors.values()])
    vmax = float(np.percentile(all_err, 99.5)) if all_err.max() > 0 else 1.0
    norm = LogNorm(vmin=vmax * 1e-3, vmax=vmax)
    cmap = plt.get_cmap("viridis").copy()
    cmap.set_under(cmap(0.0))
    axes[0][0].imshow(show(C.read_pfm(ref)), interpolation="nearest")
    axes[0][0].set_title(f"reference\ncanonical, {ref_spp} spp", fontsize=8)
    axes[1][0].axis("off")
    axes[1][0].text(0.5, 0.5, "error:\n(a − ref)² / (ref² + 0.01)\nmean over RGB,\nlog scale", ha="center",
                    va="center", fontsize=7.5, transform=axes[1][0].transAxes)
    im = None
    for j, row in enumerate(rows, start=1):
        key = row["method"]
        axes[0][j].imshow(show(images[key]), interpolation="nearest")
        axes[0][j].set_title(f"{row['label']}\n{row['spp']} spp, {row['seconds']:.2f} s", fontsize=8)
        im = axes[1][j].imshow(np.maximum(errors[key], vmax * 1e-4), norm=norm, cmap=cmap, interpolation="nearest")
        psnr = f"{row['psnr_db']:.1f} dB" if np.isfinite(row["psnr_db"]) else "inf"
        axes[1][j].set_title(f"relMSE {row['relmse']:.4f}, PSNR {psnr}", fontsize=8)
    for a in axes.ravel():
        a.set_xticks([])
        a.set_yticks([])
    cb = fig.colorbar(im, cax=cax)
    cb.set_label("relative squared error", fontsize=7)
    rounds = len(final["canonical"])
    fig.suptitle(f"{scene_name}, {size}, path traced, equal time: each method gets the canonical configuration's "
                 f"time at {budget_spp} spp ({budget:.2f} s, 1 thread);\nthe spp from a pilot render, the times "
                 f"shown: median over {rounds} round{'s' if rounds > 1 else ''} of the final render",
                 fontsize=9, y=0.995)
    fig.savefig(ctx.out / "methods_figure.png", dpi=100, bbox_inches="tight")

    header = ["method", "spp", "render s", "relMSE", "PSNR", "steps/camera ray", "memory"]
    trows = [[r["label"], str(r["spp"]), f"{r['seconds']:.2f}", f"{r['relmse']:.5f}", f"{r['psnr_db']:.2f} dB",
              f"{r['steps_per_camera_ray']:.1f}", C.fmt_bytes(r["memory_bytes"])] for r in rows]
    exact = [r for r in rows if r["method"] != "fixedstep"]
    best = min(exact, key=lambda r: r["relmse"])
    fixed = next(r for r in rows if r["method"] == "fixedstep")
    verdict = (f"At {budget:.2f} s each ({size}, path traced, 1 thread): lowest relMSE among the exact methods "
               f"{best['label']} ({best['relmse']:.4f} at {best['spp']} spp); "
               + ", ".join(f"{r['label']} {r['relmse']:.4f} ({r['spp']} spp)" for r in rows if r is not best)
               + f". Fixed step: relMSE {fixed['relmse']:.4f}.")
    return {"status": "ok", "verdict": verdict, "tables": [C.md_table(header, trows)],
            "plots": ["methods_figure.png"], "csv": ["results.csv"],
            "numbers": {r["method"]: {"spp": r["spp"], "relmse": r["relmse"]} for r in rows}}


if __name__ == "__main__":
    sys.exit(C.main(sys.modules[__name__]))
