"""CDR fixtures made by rclpy itself (rclpy.serialization, Fast CDR through
rmw_fastrtps_cpp: what a ROS 2 node puts on DDS), for Radar's codec tests.

    fixtures.py TYPE...   (e.g. sensor_msgs/msg/LaserScan)
    fixtures.py --read    (JSON lines {"type", "cdr"} on stdin)

For each type prints one JSON line {"type", "value" (Radar's JSON form: a
record keyed by kebab-case field names, numbers as numbers), "cdr" (hex of
rclpy's serialization, with its 4-byte encapsulation header)}. Every field
is filled with a value of its own (sequences of 0 to 3 elements), the
message serialized by rclpy and read back by rclpy, and the value taken
from what was read back, so that float32 fields hold what the wire holds.
With --read, each line's CDR (Radar's, say) is deserialized by rclpy and
printed back as {"type", "value"}. Needs no network.
"""

import importlib
import itertools
import json
import sys

from rclpy.serialization import deserialize_message, serialize_message
from rosidl_parser import definition as d

LENGTHS = itertools.cycle((2, 3, 0, 1))
FLOATS = ("float", "double", "long double")


def message_class(name):
    package, kind, type_name = name.split("/")
    return getattr(importlib.import_module(f"{package}.{kind}"), type_name)


class Filler:
    """Gives every leaf a value of its own."""

    def __init__(self):
        self.n = 0

    def message(self, cls):
        msg = cls()
        for (name, _), slot in zip(cls.get_fields_and_field_types().items(), cls.SLOT_TYPES):
            setattr(msg, name, self.value(slot))
        return msg

    def value(self, slot):
        if isinstance(slot, d.Array):
            return [self.value(slot.value_type) for _ in range(slot.size)]
        if isinstance(slot, d.AbstractSequence):
            length = next(LENGTHS)
            if isinstance(slot, d.BoundedSequence):
                length = min(length, slot.maximum_size)
            items = [self.value(slot.value_type) for _ in range(length)]
            if isinstance(slot.value_type, d.BasicType) and slot.value_type.typename in (
                "octet",
                "uint8",
            ):
                # An octet is one byte of its own (see `basic`).
                return b"".join(items) if slot.value_type.typename == "octet" else items
            return items
        if isinstance(slot, d.AbstractString):
            self.n += 1
            text = f"text {self.n} é"
            if isinstance(slot, d.BoundedString):
                text = text[: slot.maximum_size]
            return text
        if isinstance(slot, d.NamespacedType):
            return self.message(message_class("/".join(slot.namespaces + [slot.name])))
        self.n += 1
        return self.basic(slot.typename, self.n)

    @staticmethod
    def basic(typename, n):
        if typename == "boolean":
            return n % 2 == 1
        if typename == "octet":
            return bytes([n % 256])
        if typename == "char":
            return chr(n % 128)
        if typename in FLOATS:
            return n + 0.1
        if typename.startswith("int"):
            bits = int(typename[3:])
            return n % (1 << (bits - 1)) * (-1 if n % 3 == 0 else 1)
        if typename.startswith("uint"):
            return n % (1 << int(typename[4:]))
        raise ValueError(f"unknown basic type {typename}")


def radar_value(value, slot):
    """Radar's JSON form of a value rclpy read back."""
    if isinstance(slot, (d.Array, d.AbstractSequence)):
        return [radar_value(v, slot.value_type) for v in value]
    if isinstance(slot, d.AbstractString):
        return value
    if isinstance(slot, d.NamespacedType):
        return radar_message(value)
    typename = slot.typename
    if typename == "octet":
        return value[0] if isinstance(value, (bytes, bytearray)) else int(value)
    if typename == "char":
        return ord(value) if isinstance(value, str) else int(value)
    if typename == "boolean":
        return bool(value)
    if typename in FLOATS:
        return float(value)
    return int(value)


def radar_message(msg):
    cls = type(msg)
    return {
        name.replace("_", "-"): radar_value(getattr(msg, name), slot)
        for name, slot in zip(cls.get_fields_and_field_types(), cls.SLOT_TYPES)
    }


def main():
    if sys.argv[1:] == ["--read"]:
        for line in sys.stdin:
            given = json.loads(line)
            read = deserialize_message(bytes.fromhex(given["cdr"]), message_class(given["type"]))
            print(json.dumps({"type": given["type"], "value": radar_message(read)}))
        return
    for name in sys.argv[1:]:
        cls = message_class(name)
        sent = Filler().message(cls)
        cdr = serialize_message(sent)
        read = deserialize_message(cdr, cls)
        print(json.dumps({"type": name, "value": radar_message(read), "cdr": cdr.hex()}))


if __name__ == "__main__":
    main()
