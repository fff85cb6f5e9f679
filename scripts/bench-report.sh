#!/usr/bin/env bash
# Prints criterion results as Markdown ratio tables: every entry of a group against the
# group's baseline (the entry whose name starts with "baseline"), measured in the same run.
# Usage: scripts/bench-report.sh [criterion-dir]   (run `cargo bench -p massid-bench` first)
set -euo pipefail
dir="${1:-${CARGO_TARGET_DIR:-target}/criterion}"
python3 - "$dir" <<'PY'
import json, os, sys
root = sys.argv[1]
if not os.path.isdir(root):
    sys.exit(f"{root}: no criterion results (run `cargo bench -p massid-bench` first)")
for group in sorted(os.listdir(root)):
    gdir = os.path.join(root, group)
    rows = []
    for bench in sorted(os.listdir(gdir)):
        est = os.path.join(gdir, bench, "new", "estimates.json")
        if os.path.isfile(est):
            with open(est) as f:
                rows.append((bench, json.load(f)["mean"]["point_estimate"]))
    base = [t for b, t in rows if b.startswith("baseline")]
    if not rows or not base:
        continue
    print(f"\n**{group}**\n\n| implementation | mean time | speed vs baseline |\n|---|---|---|")
    for b, t in rows:
        unit, scale = ("ms", 1e6) if t >= 1e6 else (("us", 1e3) if t >= 1e3 else ("ns", 1.0))
        print(f"| {b} | {t/scale:.3g} {unit} | {base[0]/t:.2f}x |")
PY
