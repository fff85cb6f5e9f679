# Writes a model file (the craft of examples/models/CRAFT.toml with one planted effect) for
# scripts/diagnose_craft_mc.sh: CASE is nominal, delayMS, latencyMS or tiltDEG (thruster 2).
# Usage: python3 scripts/diagnose_craft_truth.py CRAFT CASE OUT.toml (from the workspace root)
import numpy as np, sys, re, tomllib
craft, case, out = sys.argv[1], sys.argv[2], sys.argv[3]
src = open(f'examples/models/{craft}.toml').read()
base = "\n".join(l for l in src.splitlines() if not l.startswith('#'))
m = tomllib.loads(src)
eff = ""
if case.startswith("delay"):
    eff = '[[effects]]\neffect = "measurement_delay"\nparams = { delay_ms = %s }\n' % case[5:]
elif case.startswith("latency"):
    v = case[7:]
    eff = '[[effects]]\neffect = "thruster_latency"\nparams = { open_ms = %s, close_ms = %s }\n' % (v, v)
elif case.startswith("tilt"):
    deg = float(case[4:]); dirs = [list(d) for d in m["thrust_dir"]]
    i = 1; d = np.array(dirs[i], float); d /= np.linalg.norm(d)
    ax = np.cross(d, [0, 0, 1.0]);
    if np.linalg.norm(ax) < 0.1: ax = np.cross(d, [1.0, 0, 0])
    ax /= np.linalg.norm(ax); th = np.radians(deg)
    r = d*np.cos(th) + np.cross(ax, d)*np.sin(th) + ax*np.dot(ax, d)*(1-np.cos(th))
    dirs[i] = list(r)
    eff = '[[effects]]\neffect = "thruster_misalignment"\nparams = { dir = [' + ", ".join("[%.6f, %.6f, %.6f]" % tuple(x) for x in dirs) + '] }\n'
open(out, 'w').write("[satellite]\n" + base + "\n\n" + eff)
