#!/usr/bin/python3
"""Ablation: swap the splitter strategy of the canonical configuration, everything else
fixed (experiments/lib/ablation.py).

    /usr/bin/python3 experiments/ablation_splitter/run.py [--quick] [--build DIR] [--out DIR] [--reps N]
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "lib"))
import ablation  # noqa: E402
import common as C  # noqa: E402

NAME = "ablation_splitter"
TITLE = "Ablation: splitter (one component swapped from the canonical configuration)"
HYPOTHESIS = ("RMIP paper §4.3: the canonical 2D midpoint split of the longer side (Fig. 5c) is at least as good as splitting at the t-midpoint (Fig. 5b, Patterson et al.), and better than TFDM's node-aligned quadtree splits (which cannot adapt to the ray).")


def run(ctx):
    return ablation.run(ctx, "splitter")


if __name__ == "__main__":
    sys.exit(C.main(sys.modules[__name__]))
