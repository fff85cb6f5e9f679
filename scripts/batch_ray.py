#!/usr/bin/env python3
"""Diagnose many recordings with Ray: the recipe of issue 25 item 4 ("past one machine").

Ray maps the per-recording command over the files; nothing here schedules anything.
Each task runs

    massid diagnose FILE [options] --json TMP/NAME.json --summary-row

on whichever Ray worker it lands, and returns the recording's massid-diagnosis/1 JSON
text (the exact bytes `massid diagnose FILE --json` writes) and its summary row (the row
`massid diagnose --out DIR` puts in summary.jsonl). The driver writes DIR/KEY.json and
DIR/summary.jsonl (rows sorted by file), so the workers need no shared output folder;
they need `massid` on their PATH (or --massid) and the recordings at the same paths.
KEY is the one `massid diagnose --out` uses: the recording's path below the deepest folder
holding every recording named (symlinks resolved), its extension replaced by .json
(a/flight.csv and b/flight.csv: DIR/a/flight.json and DIR/b/flight.json).

    python3 scripts/batch_ray.py --out DIR [--massid BIN] [--address auto] \
        [--num-cpus N] RECORDING_OR_FOLDER... [-- extra massid diagnose options]

Local mode (the default) starts a Ray instance on this machine with --num-cpus workers;
`--address auto` (or ray://HOST:10001) joins a running cluster instead.
Exit status 1 when any recording could not be diagnosed (its row says why), like
`massid diagnose --out`.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

# The fields of a summary row, in massid's order (cmd/diagnose.rs `Row`, `CSV_HEADER`): an
# error row written here carries them all, as massid's own rows do.
ROW_FIELDS = ("file", "status", "model", "samples", "effects", "params",
              "residual_rms_before", "residual_rms_after", "unexplained", "error", "seconds")


def recordings(paths):
    """The recordings named: a folder gives its *.csv files, sorted, but a batch's own
    summary.csv (as massid does); the same recording twice, however spelled, is one."""
    found = []
    for p in paths:
        if os.path.isdir(p):
            names = sorted(n for n in os.listdir(p)
                           if n.lower().endswith(".csv") and n != "summary.csv")
            found.extend(os.path.join(p, n) for n in names
                         if os.path.isfile(os.path.join(p, n)))
        else:
            found.append(p)
    seen = set()
    return [f for f in found
            if not (os.path.realpath(f) in seen or seen.add(os.path.realpath(f)))]


def json_keys(files):
    """Each recording's JSON below --out, as massid diagnose --out names it (batch.rs
    json_keys): its path relative to the deepest folder holding every recording (symlinks
    resolved), the extension replaced by .json."""
    real = [os.path.realpath(f) for f in files]
    if not real:
        return []
    root = os.path.commonpath([os.path.dirname(r) for r in real])
    return [os.path.splitext(os.path.relpath(r, root))[0] + ".json" for r in real]


def error_row(recording, error, seconds):
    """The row of a recording massid printed no row for (its argument parser rejected an
    option; every later refusal prints its own error row), as massid writes an error row (`Row::error`): every field, in order, the
    line compact and non-ASCII unescaped like serde_json's."""
    row = dict.fromkeys(ROW_FIELDS)
    row.update(file=recording, status="error", effects=[], params=[], error=error,
               seconds=round(seconds, 3))
    return json.dumps(row, separators=(",", ":"), ensure_ascii=False)


def diagnose(massid, recording, extra):
    """The unit of work: one `massid diagnose --summary-row` run (a Ray task in main; a
    plain function here, so that it runs and is tested without Ray)."""
    started = time.monotonic()
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "diagnosis.json")
        proc = subprocess.run(
            [massid, "diagnose", recording, *extra, "--json", out, "--summary-row"],
            capture_output=True, text=True)
        text = None
        if proc.returncode == 0 and os.path.exists(out):
            with open(out, encoding="utf-8") as f:
                text = f.read()
        lines = proc.stdout.strip().splitlines()
        if lines:  # the row exactly as massid printed it
            line = lines[-1]
        else:  # the argument parser rejected an option: no row printed
            line = error_row(recording, proc.stderr.strip(), time.monotonic() - started)
        return recording, text, line


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True, help="output folder")
    ap.add_argument("--massid", default="massid", help="the massid binary")
    ap.add_argument("--address", default=None,
                    help="a Ray cluster to join (default: local mode on this machine)")
    ap.add_argument("--num-cpus", type=int, default=None,
                    help="local mode: workers (default: every core)")
    ap.add_argument("--force", action="store_true",
                    help="replace JSONs already in --out")
    ap.add_argument("paths", nargs="+", help="recordings and folders")
    # everything after `--` goes to massid diagnose untouched (argparse would take an
    # option's value, `--horizon 10`, for a path)
    argv = sys.argv[1:]
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    own = argv[:argv.index("--")] if "--" in argv else argv
    args = ap.parse_args(own)
    files = recordings(args.paths)
    os.makedirs(args.out, exist_ok=True)
    # the output names are checked before any work, as massid diagnose --out does
    keys = dict(zip(files, json_keys(files)))
    names = {}
    for f, name in keys.items():
        if name in names:
            sys.exit(f"{f} and {names[name]} would both write {name}; rename one")
        names[name] = f
        path = os.path.join(args.out, name)
        if os.path.exists(path) and not args.force:
            sys.exit(f"{path}: exists; refusing to overwrite it (pass --force)")
    massid = os.path.abspath(args.massid) if os.path.sep in args.massid else args.massid
    import ray  # here, not at the top: the module's functions run without Ray (the tests)
    task = ray.remote(diagnose)
    if args.address:
        ray.init(address=args.address)
    else:
        ray.init(num_cpus=args.num_cpus, include_dashboard=False, log_to_driver=False)
    results = ray.get([task.remote(massid, f, extra) for f in files])
    ray.shutdown()
    rows = []
    for recording, text, line in results:
        if text is not None:
            path = os.path.join(args.out, keys[recording])
            os.makedirs(os.path.dirname(path), exist_ok=True)
            if os.path.exists(path) and not args.force:
                sys.exit(f"{path}: exists; refusing to overwrite it (pass --force)")
            tmp = path + f".tmp{os.getpid()}"
            with open(tmp, "w", encoding="utf-8") as f:
                f.write(text)
            os.replace(tmp, path)
        rows.append((json.loads(line), line))
    rows.sort(key=lambda r: r[0]["file"])
    summary = os.path.join(args.out, "summary.jsonl")
    with open(summary, "w", encoding="utf-8") as f:
        for _, line in rows:
            f.write(line + "\n")
    rows = [row for row, _ in rows]
    failed = [r for r in rows if r.get("status") != "ok"]
    print(f"diagnosed {len(rows) - len(failed)} of {len(rows)} recordings with Ray; "
          f"summary: {summary}")
    for r in failed:
        print(f"failed: {r['file']}: {r.get('error')}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
