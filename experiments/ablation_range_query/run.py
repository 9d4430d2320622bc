#!/usr/bin/python3
"""Ablation: swap the range query strategy of the canonical configuration, everything else
fixed (experiments/lib/ablation.py).

    /usr/bin/python3 experiments/ablation_range_query/run.py [--quick] [--build DIR] [--out DIR] [--reps N]
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "lib"))
import ablation  # noqa: E402
import common as C  # noqa: E402

NAME = "ablation_range_query"
TITLE = "Ablation: range query (one component swapped from the canonical configuration)"
HYPOTHESIS = ("RMIP paper §6 (ablation) and §5: swapping RMIP for a minmax mipmap (or safety zones) in the same traversal degrades performance, because the queries are anisotropic rectangles bounding ray projections.")


def run(ctx):
    return ablation.run(ctx, "range_query")


if __name__ == "__main__":
    sys.exit(C.main(sys.modules[__name__]))
