#!/usr/bin/env python3
"""Checks that the engine's layers include only downwards.

core/src/<layer>/ and core/include/frichb/core/<layer>/ hold one layer each; the order, lowest
first, is LAYERS below. A file may include headers of its own layer and of the layers below it;
an include of a higher layer is an upward include and is reported with its file and line.
core/app (the command-line program) sits above every layer; plugins/ may include only
plugin_host and what it rests on. Exit status 0 when no upward include is found, 1 otherwise.
"""
import pathlib
import re
import sys

LAYERS = ["support", "numerics", "fe_import", "plugin_host", "scene", "solver", "model", "commands", "report"]
RANK = {name: i for i, name in enumerate(LAYERS)}
INCLUDE = re.compile(r'#\s*include\s*"(?:frichb/core/)?([a-z_]+)/[a-z_0-9]+\.hpp"')


def layer_of(path: pathlib.Path, root: pathlib.Path) -> int | None:
    rel = path.relative_to(root).parts
    if rel[:2] == ("core", "src") and len(rel) > 3:
        return RANK.get(rel[2])
    if rel[:4] == ("core", "include", "frichb", "core") and len(rel) > 5:
        return RANK.get(rel[4])
    if rel[0] == "plugins":
        return RANK["plugin_host"]
    return None


def main() -> int:
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else ".").resolve()
    files = [p for d in ("core/src", "core/include", "plugins") for p in (root / d).rglob("*")
             if p.suffix in (".cpp", ".hpp", ".h")]
    upward = []
    for path in sorted(files):
        own = layer_of(path, root)
        if own is None:
            continue
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            match = INCLUDE.search(line)
            if match and match.group(1) in RANK and RANK[match.group(1)] > own:
                upward.append(f"{path.relative_to(root)}:{number}: {LAYERS[own]} includes "
                              f"{match.group(1)} ({line.strip()})")
    for entry in upward:
        print(entry)
    print(f"{len(files)} files, {len(upward)} upward includes "
          f"(layers, lowest first: {' < '.join(LAYERS)})")
    return 1 if upward else 0


if __name__ == "__main__":
    sys.exit(main())
