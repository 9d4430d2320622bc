#!/usr/bin/python3
"""Ablation: swap the inverter strategy of the canonical configuration, everything else
fixed (experiments/lib/ablation.py).

    /usr/bin/python3 experiments/ablation_inverter/run.py [--quick] [--build DIR] [--out DIR] [--reps N]
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "lib"))
import ablation  # noqa: E402
import common as C  # noqa: E402

NAME = "ablation_inverter"
TITLE = "Ablation: inverter (one component swapped from the canonical configuration)"
HYPOTHESIS = ("RMIP paper §4.2 and docs/inversion.md: the inverter only changes the cost of each inversion, never the result; Newton is the cheapest exact choice, the cubic solve costs somewhat more, Ceres (the reference) much more.")


def run(ctx):
    return ablation.run(ctx, "inverter")


if __name__ == "__main__":
    sys.exit(C.main(sys.modules[__name__]))
