#!/usr/bin/python3
"""sweep_keys.py SQUALL LAYER KEYPATH SCENE [--set K=V ...] — every numeric key of a layer at its
documented minimum and maximum (issue 17: "the documented minimum of every key").

For each key that `squall params LAYER` lists with a numeric range [lo, hi] and a scalar default,
runs `squall simulate SCENE --frames 2 --set KEYPATH.key=lo` (then =hi), with the extra --set
options (a small grid, so the sweep is quick), under a 120 s limit. Each run must end in one of:
  ran        exit 0
  refused    exit 2 with a one-line message (a rule between keys)
  failed     exit 1 with a one-line message (a runtime error: blow-up, memory limit)
and never in a signal (crash), a timeout (hang or a documented value that is unusable) or a
message of several lines. One JSON line per run; a summary line; exit 1 on any finding.

  scripts/reliability/sweep_keys.py build/release/squall sandstorm layers.storm haboob \\
      --set layers.storm.domain.nx=16 --set layers.storm.domain.ny=8 ...
"""
import json
import re
import subprocess
import sys

# "  key  unit  default D  range [lo, hi]  live|rebuild" (the last column since the viewer's
# live changes; optional so that older tables still parse)
LINE = re.compile(r"^  (\S+)\s+\S+\s+default (.+?)\s+range \[([^,\]]+), ([^\]]+)\]"
                  r"(?:\s+(?:live|rebuild))?\s*$")


def keys(squall, layer):
    out = subprocess.run([squall, "params", layer], capture_output=True, text=True).stdout
    found = []
    for line in out.splitlines():
        m = LINE.match(line)
        if not m or m.group(2).startswith("["):
            continue
        try:
            lo, hi = float(m.group(3)), float(m.group(4))
        except ValueError:
            continue
        found.append((m.group(1), m.group(3), m.group(4)))
    if not found:  # a table this script cannot read must not pass as "no findings"
        sys.exit(f"sweep_keys: no numeric key parsed from `squall params {layer}`")
    return found


def main():
    if len(sys.argv) < 5:
        raise SystemExit(__doc__)
    squall, layer, keypath, scene = sys.argv[1:5]
    extra = sys.argv[5:]
    findings = runs = 0
    counts = {}
    for key, lo, hi in keys(squall, layer):
        for value in (lo, hi):
            cmd = [squall, "simulate", scene, "--frames", "2", "--quiet", "--threads", "1"] + extra
            cmd += ["--set", "%s.%s=%s" % (keypath, key, value)]
            runs += 1
            try:
                p = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
                rc, err = p.returncode, p.stderr.strip()
            except subprocess.TimeoutExpired:
                rc, err = "timeout", ""
            lines = len([l for l in err.splitlines() if l.strip()])
            kind = {0: "ran", 2: "refused", 1: "failed"}.get(rc, "finding")
            if kind != "ran" and lines != 1:
                kind = "finding"
            counts[kind] = counts.get(kind, 0) + 1
            findings += kind == "finding"
            print(json.dumps({"key": key, "value": value, "result": kind, "rc": rc,
                              "message": err[:300]}), flush=True)
    print(json.dumps({"layer": layer, "runs": runs, **counts}))
    sys.exit(1 if findings else 0)


if __name__ == "__main__":
    main()
