#!/usr/bin/env python3
"""Plots of `pneumo reproduce hodgson2012`: paper 002's 3-mode and 7-mode sliding controllers on rig A.

Usage: plot_hodgson2012.py OUT_DIR

Reads OUT_DIR/hodgson2012.json and the logs OUT_DIR/hodgson2012_<signal>_mode<3|7>.csv, writes
  hodgson2012_tracking.png  position and chamber P's valves under both controllers for the square wave,
                            the 1.5 Hz sine and the multisine (cf. paper 002 Figs. 7-8),
  hodgson2012_sines.png     RMS error and switches per second against the sine's frequency (cf. Fig. 7a),
                            with the paper's switch counts and reductions marked.
"""
import csv
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

SIGNALS = [("square", "square wave (28)"), ("sine_1.5Hz", "1.5 Hz sine (26)"), ("multisine", "multisine (27)")]


def read_log(path):
    with open(path) as f:
        rows = [line for line in f if not line.startswith("#")]
    reader = csv.reader(rows)
    header = next(reader)
    columns = {name: [] for name in header}
    for row in reader:
        for name, value in zip(header, row):
            columns[name].append(float(value))
    return columns


def tracking(out_dir, report):
    fig, axes = plt.subplots(3, len(SIGNALS), figsize=(14, 8), dpi=110, sharex="col",
                             gridspec_kw={"height_ratios": [3, 1, 1]})
    for col, (signal, title) in enumerate(SIGNALS):
        logs = {mode: read_log(os.path.join(out_dir, f"hodgson2012_{signal}_mode{mode}.csv")) for mode in (3, 7)}
        t = logs[3]["time"]
        ax = axes[0][col]
        ax.plot(t, [1e3 * v for v in logs[3]["cyl.ref"]], color="k", lw=1, ls="--", label="$y_d$")
        for mode, color in ((3, "C3"), (7, "C0")):
            m = report[signal][f"mode{mode}"]
            ax.plot(logs[mode]["time"], [1e3 * v for v in logs[mode]["cyl.x"]], color=color, lw=1,
                    label=f"{mode}-mode: RMS {m['rms_error_mm']:.2f} mm, {m['switches_per_s']:.1f} switches/s")
        ax.set_title(title, fontsize=10)
        ax.legend(fontsize=7, loc="lower left")
        ax.set_ylabel("position (mm)" if col == 0 else "")
        for row, mode in ((1, 3), (2, 7)):
            ax = axes[row][col]
            log = logs[mode]
            ax.step(log["time"], log["cyl.u1"], where="post", color="C2", lw=0.6, label="U1 (P supply)")
            ax.step(log["time"], [-v for v in log["cyl.u2"]], where="post", color="C1", lw=0.6, label="U2 (P exhaust)")
            ax.set_yticks([-1, 0, 1])
            ax.set_ylabel(f"{mode}-mode\nvalves P" if col == 0 else "")
            if col == 0 and row == 1:
                ax.legend(fontsize=6, loc="upper right")
        axes[2][col].set_xlabel("time (s)")
    fig.suptitle("Paper 002 on rig A: 3-mode ([17]) against 7-mode sliding control "
                 "(w = 100 rad/s, xi = 0.5, tau = 40 ms, beta = 3 mm, e_min = 1 mm, 500 Hz)", fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "hodgson2012_tracking.png"))
    plt.close(fig)


def sines(out_dir, report):
    runs = sorted(report["sines"], key=lambda s: s["frequency_hz"])
    f = [s["frequency_hz"] for s in runs]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2), dpi=110)
    for mode, color in ((3, "C3"), (7, "C0")):
        ax1.plot(f, [s[f"mode{mode}"]["rms_error_mm"] for s in runs], "o-", color=color, label=f"{mode}-mode")
        ax2.plot(f, [s[f"mode{mode}"]["switches_per_s"] for s in runs], "o-", color=color, label=f"{mode}-mode")
    ax1.set_xlabel("sine frequency (Hz)")
    ax1.set_ylabel("RMS tracking error (mm)")
    ax1.set_title("tracking (cf. paper 002 Fig. 7a)", fontsize=10)
    ax2.set_xlabel("sine frequency (Hz)")
    ax2.set_ylabel("valve switches per second (all 4 valves)")
    paper = report["paper"]
    sim = report["sine_1.5Hz"]
    ax2.set_title(f"switching: at 1.5 Hz {sim['switch_reduction_pct']:.0f} % fewer with 7 modes "
                  f"(paper: {paper['sine_1.5Hz']['switch_reduction_pct']:.0f} %)", fontsize=10)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "hodgson2012_sines.png"))
    plt.close(fig)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out_dir = sys.argv[1]
    with open(os.path.join(out_dir, "hodgson2012.json")) as f:
        report = json.load(f)
    tracking(out_dir, report)
    sines(out_dir, report)


if __name__ == "__main__":
    main()
