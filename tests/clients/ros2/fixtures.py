"""Golden CDR fixtures for Radar's ROS 2 codec tests.

    fixtures.py TYPE...   (e.g. sensor_msgs/msg/Range)
    fixtures.py --all     (every type of builtin_interfaces, std_msgs,
                           geometry_msgs, sensor_msgs, nav_msgs,
                           unique_identifier_msgs, action_msgs and
                           rosgraph_msgs in
                           rosbags' ROS 2 Jazzy store)

For each type prints one JSON line {"type", "hash" (RIHS01, from rosbags),
"value" (Radar JSON), "le", "be" (hex of the CDR encoding with its 4-byte
encapsulation header, little/big endian)}. The value is deterministic and
different per field. Each fixture is checked by deserializing both encodings
back, and the hash against zenoh-ros2-sdk's own; exits 1 on any mismatch.
"""

import argparse
import itertools
import json
import sys

import ros2_common as rc
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_typestore
from zenoh_ros2_sdk.message_registry import get_registry
from zenoh_ros2_sdk.utils import get_type_hash, load_dependencies_recursive

STORE = get_typestore(Stores.ROS2_JAZZY)
SEQUENCE_LENGTHS = (2, 3, 2, 0)  # every fourth sequence is empty


class Values:
    """Generates Radar JSON for a type; n counts the leaves seen so far."""

    def __init__(self):
        self.n = 0
        self.sequences = itertools.cycle(SEQUENCE_LENGTHS)

    def message(self, typename):
        return {rc.kebab(name): self.value(desc, name) for name, desc in rc.fields(STORE, typename)}

    def value(self, desc, name):
        kind, rest = desc
        if kind == Nodetype.NAME:
            return self.message(rest)
        if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            sub, length = rest
            if kind == Nodetype.SEQUENCE:
                # `length` is a bounded sequence's bound (0: unbounded).
                length = min(next(self.sequences), length or 3)
            return [self.value(sub, name) for _ in range(length)]
        self.n += 1
        return self.base(rest[0], name, self.n)

    @staticmethod
    def base(base, name, n):
        if name == "structure_needs_at_least_one_member":
            return 0  # rosbags' stand-in field of empty messages
        if base == "bool":
            return n % 2 == 1
        if base == "string":
            return f"{rc.kebab(name)}-é{n}"
        if base in rc.FLOATS:  # multiples of 1/8: exact in float32
            return (n * 0.375 + 0.125) * (-1 if n % 2 else 1)
        return {  # rosbags packs `byte` as int8, so keep bytes in 0..127
            "byte": n % 100 + 1, "char": n % 100 + 1, "uint8": 200 + n % 50,
            "int8": -(n % 100) - 1, "uint16": 60000 + n, "int16": -30000 + n,
            "uint32": 3_000_000_000 + n, "int32": -2_000_000_000 + n,
            "uint64": 2**40 + 3 + n, "int64": -(2**40) - n,
        }[base]


# zenoh-ros2-sdk's hash of these differs from rosidl's (rcl_interfaces'
# .json files) and rosbags', which agree: it leaves out that a field has a
# default value.
SDK_HASH_WRONG = {"rcl_interfaces/msg/ParameterDescriptor"}


def sdk_hash(typename):
    registry = get_registry()
    definition = registry.get_msg_file_path(typename).read_text()
    deps = load_dependencies_recursive(typename, definition, registry)
    return get_type_hash(typename, definition, deps)


def fixture(typename):
    if typename not in STORE.fielddefs:
        raise ValueError("not a type of the ROS 2 Jazzy store")
    value = Values().message(typename)
    msg = rc.from_json(STORE, typename, value)
    out = {"type": typename, "hash": STORE.hash_rihs01(typename), "value": value}
    for key, little in (("le", True), ("be", False)):
        raw = bytes(STORE.serialize_cdr(msg, typename, little_endian=little))
        back = rc.to_json(STORE, typename, STORE.deserialize_cdr(raw, typename))
        if back != value:
            raise ValueError(f"{typename}: {key} round trip gave {back}, expected {value}")
        out[key] = raw.hex()
    if typename not in SDK_HASH_WRONG and out["hash"] != sdk_hash(typename):
        raise ValueError(f"{typename}: rosbags hash {out['hash']} != SDK hash {sdk_hash(typename)}")
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("types", nargs="*")
    parser.add_argument("--all", action="store_true")
    args = parser.parse_args()
    types = args.types
    if args.all:
        types += sorted(t for t in STORE.fielddefs if t.split("/")[0] in rc.PACKAGES)
    if not types:
        parser.error("give TYPE... or --all")
    failed = False
    for typename in types:
        try:
            print(json.dumps(fixture(typename), ensure_ascii=False), flush=True)
        except Exception as err:  # report every type, then fail
            print(f"{typename}: {err}", file=sys.stderr)
            failed = True
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
