#!/usr/bin/env python3
"""check_message_keys.py SQUALL SOURCE_DIR — every key a message names must exist.

Messages are the string literals of the C sources (errors, warnings, advice). A message "names a
key" where it writes an identifier in key form: dotted (`wind.speed_mps`, `camera.position`) or
with an underscore (`dt_max_s`), or any identifier followed by " = " (`collision = smagorinsky`).
  * In the user-facing layers (src/phen, src/scene, src/world, src/render, src/io, apps/cli)
    the name must be a scene key: a section key (world., camera., output., ...), a layer key
    with or without `layers.<type>.`, a top-level key, or a section (a prefix of keys).
  * In a solver (src/solvers/<name>) the name must be a field of one of the solver's public
    desc structs (include/squall/<name>.h): the solver's own API. Where a solver's message
    reaches scene users, the scene layer rewrites those fields into the layer's keys
    (tests/reliability/test_messages.c checks the rewriting).
The scene keys come from the binary (`squall params`), the desc fields from the headers, so
neither side is copied into this test. Prints every unknown name with file:line and fails."""
import os
import re
import subprocess
import sys

SQ, SRC = sys.argv[1], sys.argv[2]

def params(name):
    out = subprocess.run([SQ, "params", name], capture_output=True, text=True).stdout
    return [l.split()[0] for l in out.splitlines() if l.startswith("  ") and not l.startswith("    ")]

listing = subprocess.run([SQ, "params"], capture_output=True, text=True)
text = listing.stdout + listing.stderr
sections = re.search(r"sections:\s*(.*)", text).group(1).split()
layers = re.search(r"layers:\s*(.*)", text).group(1).split()
scene_keys = {"name", "description", "seed", "world", "camera", "layers", "output",
              "layers.type", "layers.name", "layers.enabled", "type", "enabled",
              "world.obstacles", "camera.path"}
# list-item sections and where their items live; any other section is a top-level key
prefix_of = {"obstacle": "world.obstacles.", "mesh": "world.meshes.", "area": "world.areas.",
             "camera-key": "camera.path."}
for s in sections:
    for k in params(s):
        scene_keys.add(prefix_of.get(s, s + ".") + k)
        if s in prefix_of:
            scene_keys.add(k)  # messages name list items as world.obstacles[i].KEY
            scene_keys.add(prefix_of[s].rstrip("."))
for l in layers:
    for k in params(l):
        scene_keys.add(k)
        scene_keys.add("layers.%s.%s" % (l, k))
def with_sections(keys):
    out = set(keys)
    for k in keys:
        parts = k.split(".")
        for i in range(1, len(parts)):
            out.add(".".join(parts[:i]))
    return out
scene_names = with_sections(scene_keys)

def api_names(header):
    """Every field of every struct and every parameter name declared in a public header."""
    names = set()
    text = re.sub(r"/\*.*?\*/", "", open(header).read(), flags=re.S)
    for m in re.finditer(r"typedef struct \w+\s*\{(.*?)\}\s*\w+;", text, re.S):
        for decl in m.group(1).split(";"):
            for n in re.findall(r"\b([a-z_][a-z0-9_]*)\s*(?:\[[^\]]*\])*\s*(?:,|$)", decl.strip()):
                names.add(n)
    for m in re.finditer(r"\b(sq_[a-z0-9]+_)?(\w+)\s*\(([^()]*)\)\s*;", text):
        names.add(m.group(2))  # "init_fields: ..." names sq_lbm_init_fields
        for arg in m.group(3).split(","):
            w = re.findall(r"([a-z_][a-z0-9_]*)\s*(?:\[[^\]]*\])*\s*$", arg.strip())
            names.update(w)
    return names

# Words that look like keys but are not advice about settings (units, file names, C names).
NOT_KEYS = re.compile(r"^(sq_|SQ_|gl_|GL_|egl|av_|nc_|png_|yaml_)|"
                      r"\.(yaml|yml|png|mp4|nc|vti|pvd|csv|pfm|json|md|glsl|h|c|sh|tmp|txt|ppm)$|"
                      r"^(e\.g|i\.e|vs|etc)$|^[0-9]")
STRING = re.compile(r'"((?:[^"\\\n]|\\.)*)"')
KEYLIKE = re.compile(r"(?<![%\w.\-/])([a-z][a-z0-9]*(?:[._][a-z0-9]+)+)(?![\w(/])")
ASSIGN = re.compile(r"(?<![%\w.\-/])([a-z][a-z0-9_.]{2,})\s=\s")
# Symbols of the physics written in messages as formulas ("c_s = 0.577", "sigma_g > 1"), not
# settings: allowed everywhere.
SYMBOLS = {"c_s", "l.u", "mu_inf", "sigma_g", "ln_sigma", "u_star", "tau_y", "mu0", "c_sat", "tau",
           "path.to.key",
           # names of the WRF file format (dimensions), which its reader's messages quote
           "bottom_top", "south_north", "west_east", "bottom_top_stag", "south_north_stag",
           "west_east_stag", "lon", "lat"}

def split_args(call):
    """Top-level arguments of a call text 'name(a, b, ...)'."""
    args, depth, cur, i = [], 0, "", call.index("(") + 1
    while i < len(call):
        c = call[i]
        if c == '"':
            j = i + 1
            while call[j] != '"':
                j += 2 if call[j] == "\\" else 1
            cur += call[i:j + 1]
            i = j + 1
            continue
        if c in "([{":
            depth += 1
        elif c in ")]}":
            if depth == 0:
                args.append(cur)
                break
            depth -= 1
        elif c == "," and depth == 0:
            args.append(cur)
            cur = ""
            i += 1
            continue
        cur += c
        i += 1
    return args

def strings_of(path):
    text = open(path, encoding="utf-8", errors="replace").read()
    text = re.sub(r"/\*.*?\*/", lambda m: " " * len(m.group(0)) if "\n" not in m.group(0)
                  else "\n" * m.group(0).count("\n"), text, flags=re.S)
    # only text that can reach a user: arguments of failing/logging/printing calls
    for m in re.finditer(r"\b(sq__fail|sq__set_error|sq_set_error|sq__cli_set_error|sq_log|"
                         r"sq_cli_error|BAD)\s*\(", text):
        line = text.count("\n", 0, m.start()) + 1
        try:
            args = split_args(text[m.start():m.start() + 8000])
        except IndexError:
            continue
        for a in args:
            lits = STRING.findall(a)
            if lits:  # every literal of the argument (a ternary gives several)
                for lit in lits if "?" in a else ["".join(lits)]:
                    yield line, lit

def check(path, allowed, what):
    bad = []
    for line, s in strings_of(path):
        s = re.sub(r"%[-+ #0-9.*]*(?:l|ll|z|h)?[a-zA-Z]", " ", s)  # drop printf conversions
        names = set(KEYLIKE.findall(s)) | set(ASSIGN.findall(s))
        for n in sorted(names):
            n = re.sub(r"\[\d*\]", "", n)
            if NOT_KEYS.search(n) or n in allowed or n in SYMBOLS or all(p in allowed for p in n.split('.')):
                continue
            bad.append("%s:%d: '%s' is not %s (in \"%s\")" % (os.path.relpath(path, SRC), line, n,
                                                              what, s[:140]))
    return bad

problems = []
# Scene scope: messages of the scene loader, the phenomena and the render/simulate command reach
# scene users, so every name in them is a scene key.
scene_files = []
# the generic phenomenon handle validates its own C API (phenomenon.h): API scope below
api_files = {os.path.join(SRC, "src/phen/phenomenon.c"): ["phenomenon.h", "plugin.h", "core.h"]}
for d in ["src/scene", "src/phen"]:
    for root, _, files in os.walk(os.path.join(SRC, d)):
        scene_files += [os.path.join(root, f) for f in sorted(files)
                        if f.endswith(".c") and os.path.join(root, f) not in api_files]
scene_files += [os.path.join(SRC, "apps/cli", f) for f in ("cmd_render.c", "run.c", "cli_run.c")]
for f in scene_files:
    if os.path.exists(f):
        problems += check(f, scene_names, "a scene key")
# API scope: the lower layers validate their own C API; a name there is a field or parameter of
# that layer's public headers (a scene user meets these messages only through a caller that
# translates them).
api_headers = {"src/render": ["render.h", "drawable.h", "world.h", "image.h", "core.h", "sqmath.h"],
               "src/io": ["io.h", "drawable.h", "world.h", "core.h", "wrf.h", "geo.h", "mesh.h"],
               "src/world": ["world.h", "core.h", "mesh.h"],
               "src/core": ["core.h", "field.h"]}
solver_root = os.path.join(SRC, "src/solvers")
for solver in sorted(os.listdir(solver_root)):
    api_headers["src/solvers/" + solver] = [solver + ".h", "core.h", "field.h"]
for f, headers in sorted(api_files.items()):
    names = set()
    for h in headers:
        names |= api_names(os.path.join(SRC, "include/squall", h))
    problems += check(f, names | scene_names, "a name of %s (%s) or a scene key" %
                      (os.path.relpath(f, SRC), ", ".join(headers)))
for d, headers in sorted(api_headers.items()):
    names = set()
    for h in headers:
        hp = os.path.join(SRC, "include/squall", h)
        if os.path.exists(hp):
            names |= api_names(hp)
    for root, _, files in os.walk(os.path.join(SRC, d)):
        for f in sorted(files):
            if f.endswith(".c"):
                problems += check(os.path.join(root, f), names | scene_names,
                                  "a name of %s's API (%s) or a scene key" % (d, ", ".join(headers)))
for p in problems:
    print(p)
print("%d unknown name(s); %d scene keys known" % (len(problems), len(scene_keys)))
sys.exit(1 if problems else 0)
