#!/usr/bin/env bash
# Issue 25 item 4: the recipe that spreads `massid diagnose` over an existing engine (Ray,
# local mode) gives what `massid diagnose --out` gives. Creates a Python venv, installs Ray
# from PyPI into it, simulates a few short recordings plus a bad one, runs
#   massid diagnose RECS --out A --jobs 2            (the built-in batch, rayon)
#   python scripts/batch_ray.py --out B RECS         (Ray mapping `massid diagnose --summary-row`)
# and checks that every JSON is byte for byte the same and the summaries have the same rows
# (but for each row's seconds), the bad recording an error row in both. A second folder holds
# a recording named like one of the first (more/a_nominal.csv): both engines give each its
# own JSON at the same key (recs/a_nominal.json, more/a_nominal.json). Every row of both
# summaries has the fields of summary.csv's header, in its order.
#
# Environment: MASSID=path/to/massid (default: built here with the test profile, the build
# `cargo test` already made), VENV=dir (default: $CARGO_TARGET_DIR/ray-venv, kept between
# runs), RAY_SPEC (default 'ray==2.60.0', the version measured here: a new release cannot change the test).
set -euo pipefail
cd "$(dirname "$0")/.."
target=${CARGO_TARGET_DIR:-target}
venv=${VENV:-$target/ray-venv}
ray_spec=${RAY_SPEC:-'ray==2.60.0'}

now() { date +%s.%N; }
took() { python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.1f} s')" "$1" "$(now)"; }

t=$(now)
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check "$ray_spec"
echo "venv with Ray ($("$venv/bin/python" -c 'import ray; print(ray.__version__)')) ready in $(took "$t")"

if [ -z "${MASSID:-}" ]; then
  cargo build --locked --profile test -p massid --bin massid
  MASSID=$target/debug/massid
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
recs=$work/recs
mkdir -p "$recs"
"$MASSID" simulate --rate 100 --maneuver single --seconds 3 --seed 1 --out "$recs/a_nominal.csv" >/dev/null
"$MASSID" simulate --rate 100 --maneuver single --seconds 3 --seed 2 \
  --model examples/models/sph2_latency.toml --out "$recs/b_latency.csv" >/dev/null
"$MASSID" simulate --rate 100 --maneuver combo --seconds 3 --seed 3 --out "$recs/c_combo.csv" >/dev/null
printf '# format = massid-recording/1\nnot,a,recording\n' >"$recs/d_bad.csv"
mkdir -p "$work/more"
"$MASSID" simulate --rate 100 --maneuver single --seconds 3 --seed 4 --out "$work/more/a_nominal.csv" >/dev/null

# Both exit 1: the bad recording fails (an error row), the others succeed.
t=$(now)
status=0
"$MASSID" diagnose "$recs" "$work/more" --out "$work/massid" --jobs 2 2>"$work/massid.log" || status=$?
[ "$status" = 1 ] || { cat "$work/massid.log"; echo "massid diagnose --out: exit $status, expected 1"; exit 1; }
echo "massid diagnose --out (rayon, 2 jobs): $(took "$t")"

t=$(now)
status=0
"$venv/bin/python" scripts/batch_ray.py --massid "$MASSID" --num-cpus 2 --out "$work/ray" "$recs" "$work/more" \
  >"$work/ray.log" 2>&1 || status=$?
[ "$status" = 1 ] || { cat "$work/ray.log"; echo "batch_ray.py: exit $status, expected 1"; exit 1; }
echo "scripts/batch_ray.py (Ray local mode, 2 CPUs, startup included): $(took "$t")"

python3 - "$work/massid" "$work/ray" <<'EOF'
import json, os, sys
a, b = sys.argv[1], sys.argv[2]
def jsons(d):
    return sorted(os.path.relpath(os.path.join(w, n), d)
                  for w, _, names in os.walk(d) for n in names if n.endswith(".json"))
def rows(d):
    out = []
    with open(os.path.join(d, "summary.jsonl")) as f:
        for line in f:
            r = json.loads(line)
            r.pop("seconds", None)
            out.append(r)
    return out
bad = []
if jsons(a) != jsons(b):
    bad.append(f"JSON files differ: {jsons(a)} vs {jsons(b)}")
for n in jsons(a):
    if open(os.path.join(a, n), "rb").read() != open(os.path.join(b, n), "rb").read():
        bad.append(f"{n}: bytes differ")
ra, rb = rows(a), rows(b)
if ra != rb:
    bad.append(f"summary rows differ:\n{ra}\n{rb}")
if [r["status"] for r in ra] != ["ok", "ok", "ok", "ok", "error"]:
    bad.append(f"statuses: {[r['status'] for r in ra]}")
# every row of both engines, ok or error, has massid's columns in their order
with open(os.path.join(a, "summary.csv")) as f:
    columns = f.readline().strip().split(",")
for d in (a, b):
    with open(os.path.join(d, "summary.jsonl")) as f:
        for line in f:
            if list(json.loads(line).keys()) != columns:
                bad.append(f"{d}: a row's fields {list(json.loads(line).keys())}, not {columns}")
if jsons(a) != ["more/a_nominal.json", "recs/a_nominal.json", "recs/b_latency.json",
                "recs/c_combo.json"]:
    bad.append(f"JSON keys: {jsons(a)}")
if bad:
    print("\n".join(bad))
    sys.exit(1)
print(f"same {len(jsons(a))} JSONs (bytes) and {len(ra)} summary rows (but seconds), "
      f"bad recording an error row in both")
EOF
echo "batch engine check passed"
