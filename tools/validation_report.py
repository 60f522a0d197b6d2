#!/usr/bin/env python3
"""Turns mpm_report's CSVs into PNG plots and a Markdown report.

    python3 tools/validation_report.py docs/validation

Reads accuracy.csv, stability.csv, machine.txt and (when there) notes.md in that directory; writes
accuracy_<case>.png, stability.png and report.md there. notes.md says which rows were run apart from the rest
(another machine, another thread count), so that their wall times are read as such.
"""
import csv
import math
import os
import sys
from collections import defaultdict

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

DEFAULT_CFL = 0.5
MARGIN = 1.2  # the default must sit this factor below the largest stable CFL number


def read(path):
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def cell(text):
    """A table cell: a metric's |x| would otherwise end the cell."""
    return text.replace("|", "\\|")


def accuracy_section(rows, out_dir):
    lines = ["## Error against run time", ""]
    if not rows:
        return lines + ["(accuracy.csv missing: run `mpm_report accuracy`)", ""]
    by_case = defaultdict(list)
    for r in rows:
        by_case[r["case"]].append(r)
    lines += ["Observed order: log2(e(h) / e(h/2)) between consecutive levels. Pass: the case's band at the",
              "finest level run, for levels at or past the band's resolution.", "",
              "| case | metric | band | choice | dx | particles | wall s | error | order | pass |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    summary = []
    for case, crs in by_case.items():
        fig, ax = plt.subplots(figsize=(5.5, 4))
        by_choice = defaultdict(list)
        for r in crs:
            by_choice[r["choice"]].append(r)
        for choice, rs in by_choice.items():
            rs.sort(key=lambda r: int(r["level"]))
            wall = [max(float(r["wall_seconds"]), 1e-4) for r in rs]
            err = [max(abs(float(r["error"])), 1e-16) for r in rs]
            ax.loglog(wall, err, "o-", label=choice)
            for i, r in enumerate(rs):
                order = ""
                if i > 0 and float(rs[i - 1]["error"]) > 0 and float(r["error"]) > 0:
                    order = "%.2f" % math.log2(float(rs[i - 1]["error"]) / float(r["error"]))
                applies = int(r["level"]) >= int(r["pass_level"])
                verdict = ("pass" if r["pass"] == "1" else "**fail**") if applies else "(coarser than band)"
                lines.append("| %s | %s | %s | %s | %.4g | %s | %.2f | %.3g | %s | %s |" % (
                    case, cell(r["metric"]) if (choice == "baseline" and i == 0) else "", cell(r["band"]) if (choice == "baseline" and i == 0) else "",
                    choice, float(r["dx"]), r["particles"], float(r["wall_seconds"]), float(r["error"]), order, verdict))
            finest = rs[-1]
            if choice == "baseline":
                summary.append((case, finest, int(finest["level"]) >= int(finest["pass_level"])))
        ax.set_xlabel("wall time [s]")
        ax.set_ylabel("error")
        ax.set_title(case)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(os.path.join(out_dir, "accuracy_%s.png" % case), dpi=90)
        plt.close(fig)
    head = ["### Verdict (baseline choice, finest level)", "", "| case | error | band | verdict | detail |", "|---|---|---|---|---|"]
    for case, r, applies in summary:
        verdict = ("pass" if r["pass"] == "1" else "**fail**") if applies else "not reached (band needs a finer level)"
        head.append("| %s | %.3g | %s | %s | %s |" % (case, float(r["error"]), cell(r["band"]), verdict, cell(r["detail"].replace(";", ", "))))
    plots = ["", "Plots: " + ", ".join("[%s](accuracy_%s.png)" % (c, c) for c in by_case), ""]
    return lines[:2] + head + plots + lines[2:] + [""]


def stability_section(rows, out_dir):
    lines = ["## Stability sweep", ""]
    if not rows:
        return lines + ["(stability.csv missing: run `mpm_report stability`)", ""]
    largest = {}
    first_fail = {}
    worst = {}
    default_fails = set()
    for r in rows:
        key = (r["setup"], r["material"], r["kernel"])
        c = float(r["cfl"])
        if r["stable"] == "1":
            largest[key] = max(largest.get(key, 0.0), c)
            worst[key] = (float(r["min_J"]), float(r["max_speed"]))
        elif key not in first_fail or c < first_fail[key][0]:
            first_fail[key] = (c, r["reason"])  # the smallest failing C: the failure just above the threshold
            if c == DEFAULT_CFL:
                default_fails.add(key)
        largest.setdefault(key, 0.0)
    setups = list(dict.fromkeys(r["setup"] for r in rows))
    materials = list(dict.fromkeys(r["material"] for r in rows))
    kernels = list(dict.fromkeys(r["kernel"] for r in rows))
    tested_max = max(float(r["cfl"]) for r in rows)
    lines += ["Largest stable CFL number C (no blow-up check fired, energy growth under 1%% over the run's substeps)."
              " C is tried in descending order from %.1f until the first stable value (stability taken as monotone in C),"
              " and the default C = %.1f is run as well; `>= %.1f` means %.1f itself was stable." % (tested_max, DEFAULT_CFL, tested_max, tested_max), ""]
    for k in kernels:
        lines += ["### %s kernel" % k, "", "| setup | " + " | ".join(materials) + " |", "|---|" + "---|" * len(materials)]
        for s in setups:
            cells = []
            for m in materials:
                key = (s, m, k)
                if key not in largest:
                    cells.append("-")
                    continue
                c = largest[key]
                cells.append((">= %.1f" % c) if key not in first_fail else ("%.1f" % c if c > 0 else "< 0.1"))
            lines.append("| %s | %s |" % (s, " | ".join(cells)))
        lines.append("")
    below = [(key, largest[key]) for key in largest
             if key in default_fails or (key in first_fail and largest[key] < DEFAULT_CFL * MARGIN)]
    if below:
        lines += ["**The default C = %.1f is not inside the stable region with a %.0f%% margin for:** " % (DEFAULT_CFL, 100 * (MARGIN - 1)) +
                  "; ".join("%s/%s/%s (largest stable %.1f; failure above it: %s)" % (key[0], key[1], key[2], c, first_fail[key][1][:120])
                            for key, c in below), ""]
    else:
        lines += ["The default C = %.1f sits inside the stable region of every case with at least a %.0f%% margin." %
                  (DEFAULT_CFL, 100 * (MARGIN - 1)), ""]
    fails = sorted(first_fail.items())
    if fails:
        lines += ["Smallest failing C per setup (cause as the engine reports it):", "", "| setup | material | kernel | C | cause |", "|---|---|---|---|---|"]
        for (s, m, k), (c, reason) in fails:
            lines.append("| %s | %s | %s | %.1f | %s |" % (s, m, k, c, reason.replace("|", "/")[:160]))
        lines.append("")
    # Picture: largest stable C per setup and material, quadratic kernel.
    fig, ax = plt.subplots(figsize=(7, 3.8))
    width = 0.8 / max(1, len(materials))
    for j, m in enumerate(materials):
        ax.bar([i + j * width for i in range(len(setups))], [largest.get((s, m, kernels[0]), 0) for s in setups], width, label=m)
    ax.axhline(DEFAULT_CFL, color="k", ls="--", lw=1, label="default C")
    ax.set_xticks([i + 0.4 - width / 2 for i in range(len(setups))])
    ax.set_xticklabels(setups, rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("largest stable C (%s)" % kernels[0])
    ax.legend(fontsize=7, ncol=3)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "stability.png"), dpi=90)
    plt.close(fig)
    total = sum(float(r["wall_seconds"]) for r in rows)
    return lines + ["![stability](stability.png)", "", "Sweep wall time: %.0f s over %d runs." % (total, len(rows)), ""]


def main():
    out_dir = sys.argv[1] if len(sys.argv) > 1 else "docs/validation"
    machine = open(os.path.join(out_dir, "machine.txt")).read().strip() if os.path.exists(os.path.join(out_dir, "machine.txt")) else "unknown"
    acc = read(os.path.join(out_dir, "accuracy.csv"))
    stab = read(os.path.join(out_dir, "stability.csv"))
    lines = ["# Validation report: error against run time, and stability", "",
             "Regenerate with `bash tools/validation_report.sh` (cases: `bench/validation/Cases.cpp`, scenes:",
             "`scenes/validation/`, bands: `docs/validation/cases.md`). Numbers below come from this machine:", "",
             "```", machine, "```", ""]
    notes = os.path.join(out_dir, "notes.md")
    if os.path.exists(notes):
        lines += [open(notes).read().strip(), ""]
    if acc:
        lines += ["Accuracy runs took %.0f s of simulation in all." % sum(float(r["wall_seconds"]) for r in acc), ""]
    lines += accuracy_section(acc, out_dir)
    lines += stability_section(stab, out_dir)
    with open(os.path.join(out_dir, "report.md.tmp"), "w") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(os.path.join(out_dir, "report.md.tmp"), os.path.join(out_dir, "report.md"))
    print("validation_report: wrote %s" % os.path.join(out_dir, "report.md"))


main()
