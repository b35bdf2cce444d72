"""Reads an MCAP trace with the MCAP reference reader (PyPI `mcap`, and
`mcap-ros2-support` for ROS 2 channels) for Radar's tests.

    read.py FILE.mcap

Prints one JSON object: the file's profile, its channels (topic, message
encoding, schema name and encoding, and whether the schema is JSON), how
many messages each channel has, the JSON Lines trace rebuilt from the
trace's messages (JSON, each a record's line) in log-time order, the
distinct differences between a record's log time and its `t` (one, 0, in
a virtual-clock run; one, the wall-clock time of t = 0, in a real-clock
one), each ROS 2 channel's messages (`cdr`), decoded by
mcap-ros2-support from the channel's own `ros2msg` schema, with their log
times, and the file's metadata records (name: their entries).
"""

import json
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


def plain(value):
    """A decoded ROS 2 message as plain JSON."""
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, (bytes, bytearray)):
        return list(value)
    if hasattr(value, "__slots__"):
        return {k: plain(getattr(value, k)) for k in value.__slots__}
    if hasattr(value, "__dict__"):
        return {k: plain(v) for k, v in vars(value).items()}
    return value


def main():
    with open(sys.argv[1], "rb") as f:
        reader = make_reader(f)
        ros2_decoders = DecoderFactory()
        decoders = {}
        header = reader.get_header()
        summary = reader.get_summary()
        channels = {}
        for channel in summary.channels.values():
            schema = summary.schemas.get(channel.schema_id)
            is_json = channel.message_encoding == "json"
            channels[channel.topic] = {
                "message_encoding": channel.message_encoding,
                "schema": schema.name if schema else None,
                "schema_encoding": schema.encoding if schema else None,
                "schema_is_json": is_json and bool(schema) and isinstance(json.loads(schema.data), dict),
                "messages": summary.statistics.channel_message_counts.get(channel.id, 0),
            }
        lines = []
        offsets = set()
        ros2 = {}
        for schema, channel, message in reader.iter_messages(log_time_order=True):
            if channel.message_encoding == "json":
                record = json.loads(message.data)
                offsets.add(message.log_time - record["t"])
                lines.append(message.data.decode())
            else:
                if channel.id not in decoders:
                    decoders[channel.id] = ros2_decoders.decoder_for(
                        channel.message_encoding, schema
                    )
                decoded = decoders[channel.id](message.data)
                ros2.setdefault(channel.topic, []).append(
                    {"log_time": message.log_time, "schema": schema.name, "message": plain(decoded)}
                )
        metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
    print(json.dumps({
        "metadata": metadata,
        "profile": header.profile,
        "channels": channels,
        "message_count": summary.statistics.message_count,
        "jsonl": "".join(line + "\n" for line in lines),
        "log_time_offsets": sorted(offsets),
        "ros2": ros2,
    }))


if __name__ == "__main__":
    main()
