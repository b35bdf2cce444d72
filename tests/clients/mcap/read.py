"""Reads an MCAP trace with the MCAP reference reader (PyPI `mcap`) for
Radar's tests.

    read.py FILE.mcap

Prints one JSON object: the file's profile, its channels (topic, message
encoding, schema name and encoding, and whether the schema is JSON), how
many messages each channel has, and the JSON Lines trace rebuilt from the
messages in log-time order (each message's data is a record's line).
"""

import json
import sys

from mcap.reader import make_reader


def main():
    with open(sys.argv[1], "rb") as f:
        reader = make_reader(f)
        header = reader.get_header()
        summary = reader.get_summary()
        channels = {}
        for channel in summary.channels.values():
            schema = summary.schemas.get(channel.schema_id)
            channels[channel.topic] = {
                "message_encoding": channel.message_encoding,
                "schema": schema.name if schema else None,
                "schema_encoding": schema.encoding if schema else None,
                "schema_is_json": bool(schema) and isinstance(json.loads(schema.data), dict),
                "messages": summary.statistics.channel_message_counts.get(channel.id, 0),
            }
        lines = []
        for _schema, channel, message in reader.iter_messages(log_time_order=True):
            record = json.loads(message.data)
            assert record["t"] == message.log_time, (record, message.log_time)
            lines.append(message.data.decode())
    print(json.dumps({
        "profile": header.profile,
        "channels": channels,
        "message_count": summary.statistics.message_count,
        "jsonl": "".join(line + "\n" for line in lines),
    }))


if __name__ == "__main__":
    main()
