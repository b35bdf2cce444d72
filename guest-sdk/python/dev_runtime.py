"""Writes the world's classes for Radar's Python development runtime.

    python3 dev_runtime.py BINDINGS_DIR RADAR_DEV_PY OUT_MODULE

BINDINGS_DIR is what `componentize-py bindings` wrote for the plugin's
world; the protocols in `wit_world/__init__.py` (the world's own exports)
and `wit_world/exports/__init__.py` (its exported interfaces) name the
classes and methods the runtime must export. Each generated method hands
the call to the plugin's own class of the same name (see radar_dev.py).
"""

import re
import sys
from pathlib import Path


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
