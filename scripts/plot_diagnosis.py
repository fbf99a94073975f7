#!/usr/bin/env python3
"""Plots of `pneumo diagnose --report DIR`: reads DIR/diagnosis.json and DIR/series.csv, writes
signals.png (measured vs simulated before and after), closeup.png (the worst window and its
neighbours), where.png (the gap per regime and over time), residual.png (what the verdict's model
leaves: its residual against the states it depends on, and over the stroke), residual_regimes.png
(that residual's RMS per regime), ranking_<round>.png (held-out shrink of every candidate) and
whiteness.png (residual autocorrelation before and after)."""
import csv
import json
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def state_unit(name):
    """(unit, factor from SI) of a signal or state by its log name: pressures in kPa, position in mm,
    velocity in mm/s, acceleration in m/s^2, commands as logged"""
    kind = name.rsplit(".", 1)[-1]
    if kind.startswith("p_"):
        return "kPa", 1e-3
    if kind == "x":
        return "mm", 1e3
    if kind == "v":
        return "mm/s", 1e3
    if kind == "a":
        return "m/s$^2$", 1.0
    return "command", 1.0


def residual_signals(report, limit=4):
    """the signals whose residual is structured, most systematic first; if none is, the two whose gap
    is the largest against its floor"""
    u = report["verdict"]["unexplained"]["signals"]

    def ratio(s, key):
        return (u[s][key] or 0) / u[s]["floor"] if u[s]["floor"] else 0

    structured = sorted((s for s in u if u[s]["structured"]), key=lambda s: -ratio(s, "systematic"))
    if structured:
        return structured[:limit]
    return sorted(u, key=lambda s: -ratio(s, "gap"))[:2]


def plot_residual(out_dir, report, rows, column, model, changed):
    """residual.png: per chosen signal, the after-model's mean residual per bin of its three
    strongest states, and its residual over the stroke; residual_regimes.png: its RMS per regime"""
    chosen = residual_signals(report)
    u = report["verdict"]["unexplained"]["signals"]
    fig, axes = plt.subplots(len(chosen), 4, figsize=(14, 3.1 * len(chosen)), squeeze=False)
    for row_axes, s in zip(axes, chosen):
        unit, factor = state_unit(s)
        floor = (u[s]["floor"] or 0) * report["signal_scale"][s] * factor
        states = u[s]["states"][:3]
        for ax, dep in zip(row_axes[:3], states):
            sunit, sfactor = state_unit(dep["state"])
            centre = [c * sfactor for c in dep["bin_centre"]]
            mean = [m * factor for m in dep["bin_mean_residual"]]
            ax.axhspan(-floor, floor, color="tab:green", alpha=0.12, lw=0, label="$\\pm$ noise floor")
            ax.axhline(0, color="k", lw=0.6)
            ax.plot(centre, mean, color="tab:purple", lw=1.2)
            total = sum(dep["bin_count"]) or 1
            ax.scatter(centre, mean, s=[12 + 200 * c / total for c in dep["bin_count"]], color="tab:purple", zorder=3,
                       label="mean residual per bin (size: rows)")
            lag = f", lag {1e3 * dep['lag_s']:.0f} ms" if dep["lag_s"] > 0 else ""
            strength = f"$\\eta^2$ {dep['eta2']:.2f}, above chance {dep['excess']:.2f}{lag}"
            ax.set_title(f"{s} residual vs {dep['state']}\n{strength}", fontsize=8.5)
            ax.set_xlabel(f"{dep['state']} ({sunit})" if sunit != "command" else f"{dep['state']} (command, as logged)", fontsize=8)
            ax.set_ylabel(f"residual ({unit})", fontsize=8)
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3)
        for ax in row_axes[len(states):3]:
            ax.axis("off")
        # over the stroke: every held-out row's residual against the measured position, by direction
        ax = row_axes[3]
        cylinder = s.rsplit(".", 1)[0]
        x = column(cylinder + ".x.measured")
        v = column(cylinder + ".v.estimated") if cylinder + ".v.estimated" in rows[0] else [math.nan] * len(x)
        resting = column("regime:near-zero velocity") if "regime:near-zero velocity" in rows[0] else [0] * len(x)
        r = [a - m for a, m in zip(column(s + ".after"), column(s + ".measured"))]
        groups = (("extending (v > 0)", "tab:blue", lambda i: not resting[i] and v[i] > 0),
                  ("retracting (v < 0)", "tab:orange", lambda i: not resting[i] and v[i] < 0),
                  ("near-zero velocity", "0.6", lambda i: resting[i] or not v[i] == v[i]))
        ax.axhspan(-floor, floor, color="tab:green", alpha=0.12, lw=0)
        ax.axhline(0, color="k", lw=0.6)
        for label, color, member in groups:
            idx = [i for i in range(len(r)) if not math.isnan(r[i]) and member(i)]
            ax.scatter([x[i] * 1e3 for i in idx], [r[i] * factor for i in idx], s=3, color=color, alpha=0.5, lw=0,
                       label=label)
        ax.set_title(f"{s} residual over the stroke\n(every held-out row)", fontsize=8.5)
        ax.set_xlabel(f"{cylinder}.x measured (mm)", fontsize=8)
        ax.set_ylabel(f"residual ({unit})", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6.5, markerscale=3, loc="best")
    axes[0][0].legend(fontsize=6.5, loc="best")
    fig.suptitle(f"What is left: residual (simulated - measured) of the verdict's model ({model}) on the held-out "
                 "log; green band: $\\pm$ the signal's noise floor", fontsize=10)
    fig.tight_layout()
    fig.savefig(f"{out_dir}/residual.png", dpi=85)
    plt.close(fig)

    # by regime: the residual RMS of each chosen signal against its floor, of the verdict's model and,
    # if it is not the model as given (`changed`), of the model as given; regimes without a row left out
    regimes = [k[len("regime:"):] for k in rows[0] if k.startswith("regime:")]
    regimes = [k for k in regimes if any(column("regime:" + k))]
    models = [("after", "tab:blue", f"verdict's model ({model})")]
    if changed:
        models.insert(0, ("before", "tab:red", "model as given"))
    width = 0.8 / len(models)
    fig, axes = plt.subplots(1, len(chosen), figsize=(4.6 * len(chosen), 3.6), squeeze=False)
    for ax, s in zip(axes[0], chosen):
        unit, factor = state_unit(s)
        floor = (u[s]["floor"] or 0) * report["signal_scale"][s] * factor
        measured = column(s + ".measured")
        for number, (key, color, label) in enumerate(models):
            values = column(f"{s}.{key}")
            rms = []
            for k in regimes:
                member = column("regime:" + k)
                e = [values[i] - measured[i] for i in range(len(values)) if member[i] and not math.isnan(values[i])]
                rms.append(math.sqrt(sum(d * d for d in e) / len(e)) * factor if e else 0)
            offset = (number - (len(models) - 1) / 2) * width
            ax.bar([i + offset for i in range(len(regimes))], rms, width=width, color=color, label=label)
        e = [a - m for a, m in zip(column(s + ".after"), measured) if not math.isnan(a)]
        ax.axhline(math.sqrt(sum(d * d for d in e) / max(len(e), 1)) * factor, color="0.3", ls=":", lw=1.2,
                   label="verdict's model, whole log")
        ax.axhline(floor, color="tab:green", ls="--", lw=1.2, label="noise floor")
        ax.set_xticks(range(len(regimes)))
        fraction = report["regime_fraction"]
        shares = [100 * fraction.get(k, 0) for k in regimes]
        ax.set_xticklabels([f"{k} ({p:.0f} %)" if p >= 0.5 else f"{k} (<1 %)" for k, p in zip(regimes, shares)], fontsize=7,
                           rotation=30, ha="right")
        ax.set_ylabel(f"residual RMS ({unit})", fontsize=8)
        ax.set_title(f"{s}: residual by regime", fontsize=9)
        ax.tick_params(axis="y", labelsize=7)
        ax.grid(alpha=0.3, axis="y")
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper center", ncol=len(labels), fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0, 1, 0.92))
    fig.savefig(f"{out_dir}/residual_regimes.png", dpi=85)
    plt.close(fig)


def main(out_dir):
    with open(f"{out_dir}/diagnosis.json") as f:
        report = json.load(f)
    with open(f"{out_dir}/series.csv") as f:
        rows = list(csv.DictReader(f))
    time = [float(r["time"]) for r in rows]
    signals = list(report["signal_scale"].keys())

    def column(name):
        return [float(r[name]) if r[name] != "" else math.nan for r in rows]

    verdict = report["verdict"]["effect"]
    # what the "after" model is: the calibration, if kept, and the established effects
    effects = report["verdict"]["effects"]
    calibrated = report["verdict"]["calibration"]["status"].startswith("fitted") and bool(report["verdict"]["calibration"]["params"])
    after_label = ("calibrated, " if calibrated else "") + ("with " + ", ".join(effects) if effects else "no effect added")
    # measured vs simulated, with the rows where the gap is largest shaded by regime
    fig, axes = plt.subplots(len(signals), 1, figsize=(11, 2.6 * len(signals)), sharex=True)
    for ax, s in zip(axes, signals):
        unit, factor = ("kPa", 1e-3) if ".p_" in s else ("mm", 1e3)
        ax.plot(time, [v * factor for v in column(s + ".measured")], color="0.45", lw=0.8, label="measured")
        ax.plot(time, [v * factor for v in column(s + ".before")], color="tab:red", lw=0.9, label="model as given")
        ax.plot(time, [v * factor for v in column(s + ".after")], color="tab:blue", lw=0.9, label=after_label)
        ax.set_ylabel(f"{s} ({unit})")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", ncol=3, fontsize=8)
    axes[0].set_title(f"Held-out log: short-horizon predictions; verdict {verdict}; gap "
                      f"{report['verdict']['heldout_gap_before']:.4f} -> {report['verdict']['heldout_gap_after']:.4f}")
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    fig.savefig(f"{out_dir}/signals.png", dpi=90)
    plt.close(fig)

    # a close look: 1.5 s around the prediction window the model as given gets most wrong
    t = report["over_time"]
    worst = max(range(len(t["gap_before"])), key=lambda i: t["gap_before"][i] or 0)
    t0 = t["window_start_s"][worst] - 0.5
    rows_zoom = [i for i, x in enumerate(time) if t0 <= x <= t0 + 1.5]
    fig, axes = plt.subplots(len(signals), 1, figsize=(11, 2.4 * len(signals)), sharex=True)
    for ax, s in zip(axes, signals):
        unit, factor = ("kPa", 1e-3) if ".p_" in s else ("mm", 1e3)
        zt = [time[i] for i in rows_zoom]
        for key, color, label in ((".measured", "0.45", "measured"), (".before", "tab:red", "model as given"),
                                  (".after", "tab:blue", after_label)):
            values = column(s + key)
            ax.plot(zt, [values[i] * factor for i in rows_zoom], color=color, lw=1.0, label=label,
                    marker="." if key == ".measured" else None, ms=2)
        ax.set_ylabel(f"{s} ({unit})")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", ncol=3, fontsize=8)
    axes[0].set_title(f"Close-up: the window with the largest gap before (t = {t['window_start_s'][worst]:.2f} s); "
                      "each window restarts from the measured state")
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    fig.savefig(f"{out_dir}/closeup.png", dpi=90)
    plt.close(fig)

    # where: per regime and over time
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 3.8))
    regimes = list(report["before"]["regimes"].keys())
    before = [report["before"]["regimes"][k] or 0 for k in regimes]
    after = [report["after"]["regimes"][k] or 0 for k in regimes]
    x = range(len(regimes))
    a.bar([i - 0.2 for i in x], before, width=0.4, color="tab:red", label="model as given")
    a.bar([i + 0.2 for i in x], after, width=0.4, color="tab:blue", label=after_label)
    a.axhline(report["verdict"]["heldout_gap_before"], color="tab:red", ls="--", lw=0.8)
    a.set_xticks(list(x))
    a.set_xticklabels([f"{k} ({100 * report['regime_fraction'][k]:.0f} %)" for k in regimes], fontsize=7, rotation=30,
                      ha="right")
    a.set_ylabel("normalised RMS gap")
    a.set_title("Gap by regime (dashed: overall)")
    a.legend(fontsize=8)
    t = report["over_time"]
    b.plot(t["window_start_s"], t["gap_before"], color="tab:red", label="model as given")
    b.plot(t["window_start_s"], t["gap_after"], color="tab:blue", label=after_label)
    b.set_xlabel("window start (s)")
    b.set_ylabel("normalised RMS gap")
    b.set_title("Gap over time, per prediction window")
    b.grid(alpha=0.3)
    b.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(f"{out_dir}/where.png", dpi=90)
    plt.close(fig)

    plot_residual(out_dir, report, rows, column, after_label, calibrated or bool(effects))

    # ranking of each round
    for number, rnd in enumerate(report["rounds"], start=1):
        ranking = rnd["ranking"]
        labels = [f"{c['effect']}\n{c['form'][:38]}" for c in ranking]
        values = [c["improvement_pct"] if c["improvement_pct"] is not None else 0 for c in ranking]
        colors = ["tab:green" if c["explains"] else ("0.7" if c["status"] == "fitted" else "tab:red") for c in ranking]
        fig, ax = plt.subplots(figsize=(10, 0.45 * len(ranking) + 1.2))
        ax.barh(range(len(ranking)), values, color=colors)
        ax.set_yticks(range(len(ranking)))
        ax.set_yticklabels(labels, fontsize=7)
        ax.invert_yaxis()
        for i, c in enumerate(ranking):
            text = f"dIC {c['delta_ic']:.0f}" if c["delta_ic"] is not None else c["status"][:40]
            ax.text(max(values[i], 0) + 0.5, i, text, va="center", fontsize=7)
        ax.axvline(0, color="k", lw=0.6)
        ax.set_xlabel("held-out gap shrink (%)   green: explains the gap, grey: does not, red: fit failed")
        ax.set_title(f"Round {number}: candidates ranked by the information criterion dIC; accepted: {rnd['accepted']}")
        fig.tight_layout()
        fig.savefig(f"{out_dir}/ranking_{number}.png", dpi=90)
        plt.close(fig)

    # residual whiteness: autocorrelation of the normalised residuals, before and after
    fig, axes = plt.subplots(1, len(signals), figsize=(4 * len(signals), 3.2))
    for ax, s in zip(axes, signals):
        for key, color in (("before", "tab:red"), ("after", "tab:blue")):
            r = [p - m for p, m in zip(column(f"{s}.{key}"), column(f"{s}.measured")) if not math.isnan(p)]
            n = len(r)
            mean = sum(r) / max(n, 1)
            c0 = sum((v - mean) ** 2 for v in r) or 1
            lags = range(0, min(60, n))
            rho = [sum((r[i] - mean) * (r[i - l] - mean) for i in range(l, n)) / c0 for l in lags]
            ax.plot(list(lags), rho, color=color, label=key)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_title(f"{s}: Ljung-Box Q {report['before']['signals'][s]['ljung_box_q']:.0f} -> "
                     f"{report['after']['signals'][s]['ljung_box_q']:.0f}", fontsize=9)
        ax.set_xlabel("lag (rows)")
    axes[0].set_ylabel("autocorrelation of residuals")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(f"{out_dir}/whiteness.png", dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main(sys.argv[1])
