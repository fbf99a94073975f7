#!/usr/bin/env python3
"""Plots of `pneumo study`: each figure of merit against each parameter.

Usage: plot_study.py DIR PARAMETERS

Reads DIR/results.csv (columns: point, the PARAMETERS parameter columns -- or, in a study over
logs, the log -- then the figures of merit, status, error) and writes DIR/plots/<figure>.png: one
panel per parameter, a dot per point that finished ok (a study over logs: the figure per log).
Figures that are not numbers (a diagnosis' verdict) are not plotted.
"""
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def number(text):
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    folder, count = sys.argv[1], int(sys.argv[2])
    with open(os.path.join(folder, "results.csv"), newline="") as f:
        rows = list(csv.reader(f))
    header, rows = rows[0], [r for r in rows[1:] if r[-2] == "ok"]
    parameters = header[1:1 + count]
    figures = header[1 + count:-2]
    os.makedirs(os.path.join(folder, "plots"), exist_ok=True)
    by_log = parameters == ["log"]
    for j, figure in enumerate(figures, start=1 + count):
        values = [number(r[j]) for r in rows]
        if not any(v is not None for v in values):
            continue
        panels = max(len(parameters), 1)
        fig, axes = plt.subplots(1, panels, figsize=(4.2 * panels, 3.4), dpi=100, squeeze=False)
        for i, parameter in enumerate(parameters or ["point"]):
            ax = axes[0][i]
            if by_log or not parameters:
                xs = list(range(len(rows)))
                ax.set_xticks(xs)
                ax.set_xticklabels([os.path.basename(r[1]) if by_log else r[0] for r in rows], rotation=60,
                                   fontsize=7, ha="right")
            else:
                xs = [number(r[1 + i]) for r in rows]
            points = [(x, y) for x, y in zip(xs, values) if x is not None and y is not None]
            ax.plot([p[0] for p in points], [p[1] for p in points], "o", ms=4, color="C0")
            ax.set_xlabel(parameter)
            ax.set_ylabel(figure)
            ax.grid(True, lw=0.3)
        fig.suptitle(f"{figure} ({len(rows)} points ok)", fontsize=9)
        fig.tight_layout()
        fig.savefig(os.path.join(folder, "plots", figure.replace("/", "_") + ".png"))
        plt.close(fig)


if __name__ == "__main__":
    main()
