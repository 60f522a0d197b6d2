#!/usr/bin/env bash
# Strong and weak scaling over MPI ranks x threads on this machine (docs/performance/ranks.md): 1M water
# particles on 1 rank x 1 and 2 threads and 2 ranks x 1 thread; 5e5 particles per rank for weak scaling;
# 3 and 4 ranks oversubscribed (more ranks than cores: for correctness, not speed). Each configuration runs
# `repeats` times, interleaved; the median row of each is kept. Ratios are against 1 rank x 1 thread of the
# same run. Usage: tools/rank_scaling.sh [BUILD_DIR] [OUT_DIR] [repeats]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
out=${2:-docs/performance}
repeats=${3:-3}
bench="$build/bench/mpm_bench"
# --bind-to none: by default OpenMPI binds each of up to 2 ranks to one core, and a rank's threads would share it.
mpirun=(mpirun --allow-run-as-root --oversubscribe --bind-to none)
mkdir -p "$out"
raw=$(mktemp)
configs=(
  "strong 1 1 1000000" "strong 1 2 1000000" "strong 2 1 1000000"
  "weak 1 1 500000" "weak 2 1 1000000"
  "oversubscribed 3 1 1000000" "oversubscribed 4 1 1000000"
)
for ((k = 0; k < repeats; k++)); do
  for c in "${configs[@]}"; do
    read -r kind ranks threads particles <<<"$c"
    row=$("${mpirun[@]}" -np "$ranks" "$bench" ranks --material water --particles "$particles" --threads "$threads" \
      --substeps 12 --warmup 3 | sed -n 's/^row,//p')
    echo "$kind,$row" | tee -a "$raw" >&2
  done
done
python3 - "$raw" "$out" <<'PY'
import csv, statistics, sys, platform, os, subprocess
raw, out = sys.argv[1], sys.argv[2]
cols = ["kind", "experiment", "material", "particles", "ranks", "threads", "substeps", "seconds", "pss", "bytes_sent_per_substep",
        "comm_share", "ghost_leaf_share", "ghost_memory_share", "imbalance", "recuts"]
rows = [dict(zip(cols, r)) for r in csv.reader(open(raw))]
groups = {}
for r in rows:
    groups.setdefault((r["kind"], r["ranks"], r["threads"], r["particles"]), []).append(r)
med = []
for key, rs in groups.items():
    rs.sort(key=lambda r: float(r["pss"]))
    med.append(rs[len(rs) // 2])
with open(os.path.join(out, "ranks.csv"), "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=cols)
    w.writeheader()
    for r in med:
        w.writerow(r)
def find(kind, ranks, threads):
    return next(r for r in med if r["kind"] == kind and r["ranks"] == str(ranks) and r["threads"] == str(threads))
base = float(find("strong", 1, 1)["pss"])
cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), platform.processor())
lines = ["# Ranks x threads on this machine", "",
         f"Machine: {cpu}, {os.cpu_count()} hardware threads, one host (loopback). Water, quadratic kernel, 12 timed",
         f"substeps after 3 warm-up ones; the median of {len(next(iter(groups.values())))} interleaved runs per row. Ratios against",
         "1 rank x 1 thread of this run. Written by `tools/rank_scaling.sh`.", "",
         "| run | particles | ranks x threads | particle-substeps/s | vs 1x1 | bytes sent per substep (most, one rank) | time communicating (most) | ghost leaves (share of a rank's leaves) | ghost memory (share of a rank's) | imbalance |",
         "|---|---|---|---|---|---|---|---|---|---|"]
for r in med:
    lines.append(f"| {r['kind']} | {int(r['particles']):,} | {r['ranks']} x {r['threads']} | {float(r['pss']):.3g} | {float(r['pss'])/base:.2f} | "
                 f"{float(r['bytes_sent_per_substep'])/1e6:.2f} MB | {100*float(r['comm_share']):.1f}% | {100*float(r['ghost_leaf_share']):.1f}% | "
                 f"{100*float(r['ghost_memory_share']):.2f}% | {float(r['imbalance']):.3f} |")
s2 = float(find("strong", 2, 1)["pss"]); t2 = float(find("strong", 1, 2)["pss"])
w1 = float(find("weak", 1, 1)["pss"]); w2 = float(find("weak", 2, 1)["pss"])
lines += ["", f"- 2 ranks x 1 thread against 1 rank x 2 threads (1M water): {s2/t2:.2f} (target: within 10%, >= 0.90).",
          f"- Weak scaling, 5e5 particles per rank: 2 ranks do {w2/w1:.2f} times the particle-substeps of 1 (ideal 2).",
          f"- Communication share of a substep, 2 ranks: {100*float(find('strong', 2, 1)['comm_share']):.1f}% (target under 10%);"
          f" ghost memory {100*float(find('strong', 2, 1)['ghost_memory_share']):.2f}% of a rank's (target under 10%).",
          "- 3 and 4 ranks share 2 cores: their rows check that the run goes, not its speed."]
open(os.path.join(out, "ranks.md"), "w").write("\n".join(lines) + "\n")
print("\n".join(lines))
PY
rm -f "$raw"
