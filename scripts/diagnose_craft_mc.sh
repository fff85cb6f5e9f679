#!/usr/bin/env bash
# The held-out Monte Carlo of README "Sensor delay, tilted thrusters and equivalent effects":
# our simulator flies each craft with one planted effect (30 s random PWM), `massid diagnose`
# names it (or not); one line per run in OUT/results.txt. Not run by CI (about 20 min).
# Usage: scripts/diagnose_craft_mc.sh OUT "CRAFTS" "RATES" "SEEDS" "CASES"
#   e.g. scripts/diagnose_craft_mc.sh /tmp/mc "freeflyer16 airbearing-mpc" "50 250" "31 32" "nominal delay200 latency60 tilt4"
set -euo pipefail
out=$1; crafts=$2; rates=$3; seeds=$4; cases=$5
root=$(cd "$(dirname "$0")/.." && pwd)
bin=$root/target/release/massid
[ -x "$bin" ] || cargo build --release --bin massid --manifest-path "$root/Cargo.toml"
mkdir -p "$out"
cd "$root"
for craft in $crafts; do for rate in $rates; do for seed in $seeds; do for c in $cases; do
  # a tilt in the plane of a planar craft is a thrust scale: not a case there
  if [ "${c#tilt}" != "$c" ] && grep -q "^planar = true" "examples/models/$craft.toml"; then continue; fi
  n=$out/$craft-$rate-$seed-$c
  python3 scripts/diagnose_craft_truth.py "$craft" "$c" "$n.toml"
  "$bin" simulate --model "$n.toml" --maneuver random-pwm --rate "$rate" --seconds 30 --seed "$seed" --out "$n.csv" --force > /dev/null
  h=5; grep -q "^planar = true" "examples/models/$craft.toml" && h=10
  "$bin" diagnose "$n.csv" --model "examples/models/$craft.toml" --horizon $h --json "$n.json" > "$n.txt" 2>&1 || true
  if [ ! -s "$n.json" ]; then echo "$(basename "$n") ERROR: no diagnosis (see $n.txt)" >> "$out/results.txt"; continue; fi
  python3 - "$n" >> "$out/results.txt" <<'PY'
import json, sys
n = sys.argv[1]
d = json.load(open(n + ".json"))
keep = ("delay_ms", "open_ms", "close_ms", "thrusters")
named = [(e["effect"], {k: v for k, v in e["params"].items() if k in keep},
          [round(x, 2) for x in e["params"].get("tilt_deg", []) if x],
          [q["effect"] for q in e.get("equivalent_to", [])]) for e in d["effects"]]
print(n.rsplit("/", 1)[-1], named, "UNEXPLAINED" if d.get("unexplained") else "")
PY
done; done; done; done
