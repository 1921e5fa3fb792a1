"""Read an MCAP file end to end with the official Python `mcap` reader (an independent implementation
from the Rust writer and the TypeScript reader in validate_mcap.mjs).

Usage: tests/js/.venv/bin/python tests/js/read_mcap.py FILE.mcap
Prints {"messages": total, "topics": {topic: count}, "schemas": {topic: schema_name}} (plus "error"
when reading failed) and exits 0 iff the whole file was read without error and total > 0.
Needs the venv deploy/setup.sh makes: mcap, plus zstandard for our zstd-compressed chunks.
"""
import json
import sys

from mcap.reader import make_reader


def main() -> int:
    if len(sys.argv) != 2:
        print("usage: read_mcap.py FILE.mcap", file=sys.stderr)
        return 2
    topics: dict[str, int] = {}
    schemas: dict[str, str] = {}
    total = 0
    error = None
    try:
        with open(sys.argv[1], "rb") as f:
            # validate_crcs: a chunk whose bytes were damaged must fail here, not read as garbage.
            reader = make_reader(f, validate_crcs=True)
            for schema, channel, _message in reader.iter_messages():
                total += 1
                topics[channel.topic] = topics.get(channel.topic, 0) + 1
                schemas[channel.topic] = schema.name if schema is not None else ""
            # The writer's statistics must agree with what was actually read.
            summary = reader.get_summary()
            if summary is not None and summary.statistics is not None:
                if summary.statistics.message_count != total:
                    error = f"read {total} messages, statistics say {summary.statistics.message_count}"
    except Exception as e:  # any reader failure is the answer, reported as JSON
        error = f"{type(e).__name__}: {e}"
    out = {"messages": total, "topics": topics, "schemas": schemas}
    if error is not None:
        out["error"] = error
    print(json.dumps(out))
    return 0 if error is None and total > 0 else 1


if __name__ == "__main__":
    sys.exit(main())
