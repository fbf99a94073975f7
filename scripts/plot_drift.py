#!/usr/bin/env python3
"""Drift plot of `pneumo identify --heldout`: paper 000 Fig. 13 for the identified model.

Usage: plot_drift.py PARAMS.json OUT.png

The standard deviation of the multi-step prediction error against the time since the last
measurement, each chamber thin and all chambers' sequences pooled thick, in % of
p_supply - p_exhaust, beside the paper's "usually less than 4 %" and "less than 10 %" lines.
"""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    with open(sys.argv[1]) as f:
        report = json.load(f)
    drift = report["heldout"]["parametric"]
    fig, ax = plt.subplots(figsize=(7, 4.2), dpi=120)
    for i, (name, chamber) in enumerate(sorted(drift["chambers"].items())):
        curve = chamber["drift"]
        ax.plot(curve["horizon_s"], curve["std_pct"], color="0.6", lw=0.8,
                label="each chamber" if i == 0 else None)
    pooled = drift["pooled_drift"]
    ax.plot(pooled["horizon_s"], pooled["std_pct"], color="C0", lw=2.2,
            label=f"pooled ({pooled['sequences']} sequences)")
    paper = drift["paper"]
    ax.axhline(paper["usually_below_pct"], color="C2", ls="--", lw=1, label="paper 000: usually below")
    ax.axhline(paper["below_pct"], color="C3", ls="--", lw=1, label="paper 000: below")
    ax.set_xlabel("time since the last measured pressure (s)")
    ax.set_ylabel("std of prediction error (% of $P_c - P_r$)")
    ax.set_title("Multi-step pressure prediction drift on the held-out log (cf. paper 000 Fig. 13)",
                 fontsize=9)
    ax.set_xlim(0, max(pooled["horizon_s"]))
    ax.set_ylim(0, max(11, max(pooled["std_pct"]) * 1.1))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    fig.savefig(sys.argv[2])


if __name__ == "__main__":
    main()
