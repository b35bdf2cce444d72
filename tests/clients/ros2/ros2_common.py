"""Shared helpers for the ROS 2 test clients (the "ROS 2 side" of Radar's
ROS 2 bridge tests): loopback-only Zenoh settings for zenoh-ros2-sdk,
conversion between rosbags message objects and Radar JSON, a hard timeout,
and parsing of rmw_zenoh liveliness tokens.

Radar JSON: an object keyed by the ROS field names with `_` -> `-`; numbers
for integers, char/byte and floats; true/false; strings; arrays (also of
uint8/byte) for fixed arrays and sequences; objects for nested messages.

Import this module before zenoh_ros2_sdk: it sets the environment the SDK
reads when it opens its session.
"""

import atexit
import os
import shutil
import sys
import tempfile
import threading

import numpy

# Keep Zenoh on loopback: listen on 127.0.0.1 only, TCP only, no multicast
# scouting (the SDK connects to tcp/<router_ip>:<router_port> only). Unlike
# rmw_zenoh's default (gossip to routers only), also gossip to peers: Radar is
# a peer, and this lets the clients connected to it find each other (and see
# each other's liveliness tokens), as ROS 2 nodes do through a Zenoh router.
CONFIG_OVERRIDE = ";".join([
    'listen/endpoints=["tcp/127.0.0.1:0"]',
    'transport/link/protocols=["tcp"]',
    "scouting/multicast/enabled=false",
    'scouting/gossip/target={"router": ["router", "peer"], "peer": ["router", "peer"]}',
])
os.environ["ZENOH_CONFIG_OVERRIDE"] = CONFIG_OVERRIDE

# The SDK git-clones .msg files it cannot find in site-packages/messages
# (setup copies Radar's there). Point its clone cache at an empty scratch
# directory and make any attempt to clone fail loudly instead.
_cache = tempfile.mkdtemp(prefix="ros2-sdk-cache-")
os.environ["ZENOH_ROS2_SDK_CACHE"] = _cache
os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")
atexit.register(shutil.rmtree, _cache, True)

import zenoh_ros2_sdk._cache  # noqa: E402
import zenoh_ros2_sdk.message_registry  # noqa: E402
from rosbags.interfaces import Nodetype  # noqa: E402
from rosbags.serde.utils import ndtype  # noqa: E402
from zenoh_ros2_sdk.qos import QosProfile, QosReliability  # noqa: E402


def _no_clone(*args, **kwargs):
    raise RuntimeError(f"missing .msg file, refusing to clone from GitHub: {args}")


zenoh_ros2_sdk._cache.clone_to_cache = _no_clone
zenoh_ros2_sdk.message_registry.clone_to_cache = _no_clone
zenoh_ros2_sdk.message_registry.get_message_file_path = _no_clone

PACKAGES = (
    "builtin_interfaces", "std_msgs", "geometry_msgs", "sensor_msgs", "nav_msgs",
    "unique_identifier_msgs", "action_msgs", "rosgraph_msgs",
)
INTS = {"byte", "char", "int8", "int16", "int32", "int64",
        "uint8", "uint16", "uint32", "uint64"}
FLOATS = {"float32", "float64"}


def kebab(name):
    return name.replace("_", "-")


def fields(store, typename):
    """[(ros field name, rosbags field descriptor)] of a message type."""
    return store.fielddefs[typename][1]


# --- rosbags message -> Radar JSON -------------------------------------------

def to_json(store, typename, msg):
    return {kebab(name): _value_to_json(store, desc, getattr(msg, name))
            for name, desc in fields(store, typename)}


def _value_to_json(store, desc, value):
    kind, rest = desc
    if kind == Nodetype.BASE:
        base = rest[0]
        if base == "bool":
            return bool(value)
        if base in INTS:
            return int(value)
        if base in FLOATS:
            return float(value)
        return str(value)
    if kind == Nodetype.NAME:
        return to_json(store, rest, value)
    sub = rest[0]  # ARRAY or SEQUENCE: ((sub descriptor), length or bound)
    return [_value_to_json(store, sub, item) for item in value]


# --- Radar JSON -> rosbags message -------------------------------------------

def from_json(store, typename, obj):
    """Builds a message of `store`; missing fields get zero values."""
    if not isinstance(obj, dict):
        raise ValueError(f"{typename}: expected an object, got {obj!r}")
    known = {kebab(name): name for name, _ in fields(store, typename)}
    unknown = set(obj) - set(known)
    if unknown:
        raise ValueError(f"{typename}: unknown fields {sorted(unknown)}, expected {sorted(known)}")
    args = {name: _value_from_json(store, desc, obj.get(kebab(name)), f"{typename}.{name}")
            for name, desc in fields(store, typename)}
    return store.types[typename](**args)


def _value_from_json(store, desc, value, where):
    kind, rest = desc
    if kind == Nodetype.BASE:
        base = rest[0]
        if value is None:
            return {"bool": False, "string": ""}.get(base, 0.0 if base in FLOATS else 0)
        if base == "bool" and isinstance(value, bool):
            return value
        if base in INTS and isinstance(value, int) and not isinstance(value, bool):
            return value
        if base in FLOATS and isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)
        if base == "string" and isinstance(value, str):
            return value
        raise ValueError(f"{where}: {value!r} is not a {base}")
    if kind == Nodetype.NAME:
        return from_json(store, rest, {} if value is None else value)
    sub, length = rest
    if value is None:
        value = [None] * length if kind == Nodetype.ARRAY else []
    if not isinstance(value, list):
        raise ValueError(f"{where}: expected an array, got {value!r}")
    if kind == Nodetype.ARRAY and len(value) != length:
        raise ValueError(f"{where}: expected {length} elements, got {len(value)}")
    items = [_value_from_json(store, sub, item, f"{where}[{i}]") for i, item in enumerate(value)]
    if sub[0] == Nodetype.BASE and sub[1][0] != "string":
        return numpy.array(items, dtype=getattr(numpy, ndtype(sub[1][0])))
    return items


# --- misc ---------------------------------------------------------------------

def qos(reliability):
    """QosProfile for --qos reliable|best_effort (other policies: SDK defaults)."""
    return QosProfile(reliability={"reliable": QosReliability.RELIABLE,
                                   "best_effort": QosReliability.BEST_EFFORT}[reliability])


def timeout(seconds, message):
    """Ends the process with status 1 after `seconds`, printing message() (or
    message) on stderr. Runs on a thread, so it fires even while the main
    thread is blocked inside Zenoh."""
    def fire():
        sys.stdout.flush()
        sys.stderr.write((message() if callable(message) else message) + "\n")
        sys.stderr.flush()
        shutil.rmtree(_cache, True)
        os._exit(1)
    timer = threading.Timer(seconds, fire)
    timer.daemon = True
    timer.start()
    return timer


def demangle(segment):
    return "/" if segment == "%" else segment.replace("%", "/")


def ros_type(dds_type):
    """sensor_msgs::msg::dds_::Range_ -> sensor_msgs/msg/Range"""
    parts = dds_type.split("::")
    if len(parts) != 4:
        return dds_type
    return f"{parts[0]}/{parts[1]}/{parts[3].removesuffix('_')}"


def parse_token(key):
    """Parses an rmw_zenoh liveliness token key expression:
    @ros2_lv/<domain>/<zid>/<node id>/<entity id>/<kind>/<enclave>/<ns>/<node>
    [/<topic>/<dds type>/<type hash>/<qos>] (names with `/` mangled to `%`)."""
    parts = str(key).split("/")
    if len(parts) < 9 or parts[0] != "@ros2_lv":
        return None
    token = {"domain": parts[1], "zid": parts[2], "node-id": parts[3], "id": parts[4],
             "kind": parts[5], "enclave": parts[6], "namespace": demangle(parts[7]),
             "node": demangle(parts[8])}
    if len(parts) >= 13:
        token.update(topic=demangle(parts[9]), type=ros_type(parts[10]),
                     hash=parts[11], qos=parts[12])
    ns = token["namespace"].rstrip("/")
    token["fqn"] = f"{ns}/{token['node']}"
    return token
