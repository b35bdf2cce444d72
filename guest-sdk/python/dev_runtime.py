"""Writes the world's classes for Radar's Python development runtime.

    python3 dev_runtime.py BINDINGS_DIR RADAR_DEV_PY OUT_MODULE

BINDINGS_DIR is what `componentize-py bindings` wrote for the plugin's
world; the protocols in `wit_world/__init__.py` (the world's own exports)
and `wit_world/exports/__init__.py` (its exported interfaces) name the
classes and methods the runtime must export. Each generated method hands
the call to the plugin's own class of the same name (see radar_dev.py).

The runtime also imports every module of `wit_world/imports/` (each
interface the world imports: `board`, `signals`, ...) and the standard
modules in STANDARD below, because the component holds only the modules
imported when it was built: a script can then import what a build of the
same code could.
"""

import re
import sys
from pathlib import Path


# Standard modules robot code often reaches for, held by every runtime
# (a script may import any module these load, too).
STANDARD = [
    "collections",
    "dataclasses",
    "enum",
    "functools",
    "itertools",
    "json",
    "math",
    "random",
    "re",
    "statistics",
    "struct",
    "time",
    "typing",
]


def protocols(path):
    """{class: [method, ...]} of the Protocol classes in a generated file."""
    found = {}
    current = None
    if not path.exists():
        return found
    for line in path.read_text().splitlines():
        cls = re.match(r"class (\w+)\(Protocol\):", line)
        if cls:
            current = cls.group(1)
            found[current] = []
            continue
        if line and not line[0].isspace():
            current = None
        method = re.match(r"    def (\w+)\(self", line)
        if current and method:
            found[current].append(method.group(1))
    return found


def main():
    bindings, runtime, out = map(Path, sys.argv[1:4])
    world = protocols(bindings / "wit_world" / "__init__.py")
    exports = protocols(bindings / "wit_world" / "exports" / "__init__.py")
    lines = [runtime.read_text()]
    lines.append("# What a script may import: the standard modules and the world's imports.")
    lines += [f"import {name}  # noqa: F401" for name in STANDARD]
    for module in sorted((bindings / "wit_world" / "imports").glob("*.py")):
        if module.stem != "__init__":
            lines.append(f"import wit_world.imports.{module.stem}  # noqa: F401")
    if exports:
        lines.append("from wit_world import exports as _exports\n")
    for base, classes in (("wit_world", world), ("_exports", exports)):
        for name, methods in classes.items():
            lines.append(f"\nclass {name}({base}.{name}):")
            if not methods:
                lines.append("    pass")
            for method in methods:
                lines.append(f"    def {method}(self, *args):")
                lines.append(f"        return _plugin({name!r}).{method}(*args)")
            lines.append("")
    out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
