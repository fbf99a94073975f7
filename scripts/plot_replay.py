#!/usr/bin/python3
"""Plot a simulated log against the log it replays (docs/log_format.md).

usage: plot_replay.py REFERENCE.csv SIMULATED.csv OUT.png [CYLINDER]

Draws chamber pressures and piston position of both logs, and their difference,
and prints the largest pressure and position errors.
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read_log(path):
    with open(path, newline="") as f:
        rows = [line for line in f if not line.startswith("#")]
    reader = csv.DictReader(rows)
    columns = {name: [] for name in reader.fieldnames}
    for row in reader:
        for name, value in row.items():
            columns[name].append(float(value))
    return columns


def main():
    if len(sys.argv) < 4:
        print(__doc__, file=sys.stderr)
        return 2
    ref, sim = read_log(sys.argv[1]), read_log(sys.argv[2])
    out, cyl = sys.argv[3], sys.argv[4] if len(sys.argv) > 4 else "cyl"
    t = ref["time"]
    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    for signal, style in (("p_P", "tab:red"), ("p_N", "tab:blue")):
        axes[0].plot(t, [p / 1e3 for p in ref[f"{cyl}.{signal}"]], color=style, lw=2, alpha=0.4,
                     label=f"{signal} reference")
        axes[0].plot(t, [p / 1e3 for p in sim[f"{cyl}.{signal}"]], color=style, lw=0.8, label=f"{signal} simulated")
    axes[0].set_ylabel("pressure (kPa abs)")
    axes[0].legend(ncol=2, fontsize=8)
    axes[1].plot(t, [x * 1e3 for x in ref[f"{cyl}.x"]], color="k", lw=2, alpha=0.4, label="x reference")
    axes[1].plot(t, [x * 1e3 for x in sim[f"{cyl}.x"]], color="k", lw=0.8, label="x simulated")
    axes[1].set_ylabel("position (mm)")
    axes[1].legend(fontsize=8)
    worst_p = 0.0
    for signal, style in (("p_P", "tab:red"), ("p_N", "tab:blue")):
        error = [(s - r) / 1e3 for s, r in zip(sim[f"{cyl}.{signal}"], ref[f"{cyl}.{signal}"])]
        worst_p = max(worst_p, max(abs(e) for e in error))
        axes[2].plot(t, error, color=style, lw=0.8, label=f"{signal} error (kPa)")
    x_error = [(s - r) * 1e3 for s, r in zip(sim[f"{cyl}.x"], ref[f"{cyl}.x"])]
    axes[2].plot(t, x_error, color="k", lw=0.8, label="x error (mm)")
    axes[2].set_ylabel("simulated - reference")
    axes[2].set_xlabel("time (s)")
    axes[2].legend(ncol=3, fontsize=8)
    fig.suptitle(f"{sys.argv[2]} against {sys.argv[1]}", fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"{out}: max pressure error {worst_p:.2f} kPa, max position error {max(abs(e) for e in x_error):.3f} mm")
    return 0


if __name__ == "__main__":
    sys.exit(main())
