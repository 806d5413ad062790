#!/usr/bin/env python3
"""tests/layers.py — the library's layering, checked (README "Layout").

  layers.py includes ROOT        every #include under ROOT/lib/LAYER/ names a
                                 header of its own layer or of one below
  layers.py circles OBJDIR ROOT DIR..
                                 no two object files of one DIR (relative to
                                 OBJDIR) use each other's symbols, directly or
                                 round a longer circle, and no object of
                                 lib/LAYER uses one of a layer above; an
                                 object counts only while its source
                                 ROOT/DIR/NAME.c(pp) exists

The layers, lowest first, are the folders of lib/: grid (the grid and its
geometry), sim (the physics), net (the network).  A public header is
lib/LAYER/ndo/NAME.h, included as "ndo/NAME.h"; a private one sits beside
the sources of its own layer and is included by its bare name.  The
generated message headers (ndo_msg/) belong to the network layer.

Prints one line per violation ("LAYERS: ..." or "CIRCLE: ...") and exits 1
if there is any, 0 otherwise.
"""
import os
import re
import subprocess
import sys

LAYERS = ["grid", "sim", "net"]
INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]', re.M)


def include_violations(root):
    lib = os.path.join(root, "lib")
    public = {}  # "ndo/NAME.h" -> layer
    for layer in LAYERS:
        d = os.path.join(lib, layer, "ndo")
        for name in sorted(os.listdir(d)) if os.path.isdir(d) else []:
            key = "ndo/" + name
            if key in public:
                yield f"{key} is in both lib/{public[key]}/ndo and lib/{layer}/ndo"
            public[key] = layer
    for rank, layer in enumerate(LAYERS):
        base = os.path.join(lib, layer)
        for dirpath, _, files in os.walk(base):
            for f in sorted(files):
                if not f.endswith((".c", ".h", ".cpp")):
                    continue
                path = os.path.join(dirpath, f)
                rel = os.path.relpath(path, root)
                text = open(path, encoding="utf-8", errors="replace").read()
                for quote, inc in INCLUDE.findall(text):
                    if inc.startswith("ndo/"):
                        owner = public.get(inc)
                        if owner is None:
                            yield f"{rel} includes {inc}, which no layer has"
                        elif LAYERS.index(owner) > rank:
                            yield (f"{rel} includes {inc} of layer '{owner}', above "
                                   f"its own layer '{layer}'")
                    elif inc.startswith("ndo_msg/"):
                        if rank < LAYERS.index("net"):
                            yield f"{rel} includes the message header {inc} (layer 'net')"
                    elif quote == '"':
                        if "/" in inc or not os.path.exists(os.path.join(base, inc)):
                            yield (f"{rel} includes \"{inc}\": a private header must sit "
                                   f"beside its layer's sources in lib/{layer}/")


def symbols(obj):
    out = subprocess.run(["nm", "-g", obj], capture_output=True, text=True,
                         check=True).stdout
    defined, used = set(), set()
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 2 and parts[0] == "U":
            used.add(parts[1])
        elif len(parts) == 3 and parts[1] in "TDBRWVi":
            defined.add(parts[2])
    return defined, used


def cycles(graph):
    """Strongly connected components of more than one node (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def circle_violations(objdir, root, dirs):
    files = {}
    for d in dirs:
        for dirpath, _, names in os.walk(os.path.join(objdir, d)):
            for n in names:
                p = os.path.join(dirpath, n)
                src = os.path.relpath(p, objdir)[:-2]
                if n.endswith(".o") and os.path.exists(os.path.join(root, src)):
                    files[src] = symbols(p)
    if not files:
        yield f"no object files under {objdir} in {' '.join(dirs)}"
        return
    owner = {}
    for f, (defined, _) in files.items():
        for s in defined:
            owner.setdefault(s, f)
    graph = {f: set() for f in files}
    for f, (_, used) in files.items():
        for s in used:
            g = owner.get(s)
            if g and g != f:
                graph[f].add(g)
    def rank(f):
        parts = f.split("/")
        return LAYERS.index(parts[1]) if parts[0] == "lib" and parts[1] in LAYERS else None

    for f in sorted(graph):
        for g in sorted(graph[f]):
            if rank(f) is not None and rank(g) is not None and rank(g) > rank(f):
                s = sorted(x for x in files[f][1] if owner.get(x) == g)
                yield f"{f} calls up a layer into {g} ({', '.join(s[:3])})"
    for comp in cycles(graph):
        why = []
        for a in comp:
            for b in comp:
                if b in graph[a]:
                    s = sorted(x for x in files[a][1] if owner.get(x) == b)
                    why.append(f"{a} -> {b} ({', '.join(s[:3])}{', ...' if len(s) > 3 else ''})")
        yield "files that call each other: " + "; ".join(why)


def main(argv):
    if len(argv) >= 3 and argv[1] == "includes":
        bad = list(include_violations(argv[2]))
        tag = "LAYERS"
    elif len(argv) >= 5 and argv[1] == "circles":
        bad = list(circle_violations(argv[2], argv[3], argv[4:]))
        tag = "CIRCLE"
    else:
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        return 2
    for b in bad:
        print(f"{tag}: {b}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
