"""Reads an MCAP file cut short (a recording killed part-way) with Python's
mcap, independent of the Rust crate: the records up to the cut, decoded by
mcap-ros2-support from the schemas in the file. Prints one JSON object:
messages, readings and wrenches read, the last reading's header stamp, the
last wrench's fz, and the error that ended the reading (EndOfFile for a cut).

Usage: read_cut.py FILE.mcap
"""

import json
import sys

from mcap.reader import NonSeekingReader
from mcap_ros2.decoder import DecoderFactory


def main():
    out = {"messages": 0, "readings": 0, "wrenches": 0, "error": None}
    with open(sys.argv[1], "rb") as f:
        reader = NonSeekingReader(f, decoder_factories=[DecoderFactory()])
        try:
            for _schema, channel, _message, decoded in reader.iter_decoded_messages(
                log_time_order=False
            ):
                out["messages"] += 1
                stamp = decoded.header.stamp
                if channel.topic == "/biotac/readings":
                    out["readings"] += 1
                    out["last_reading_stamp_s"] = stamp.sec + stamp.nanosec * 1e-9
                elif channel.topic == "/ft_sensor/wrench":
                    out["wrenches"] += 1
                    out["last_wrench_fz"] = decoded.wrench.force.z
        except Exception as e:  # the cut: what was read stands
            out["error"] = type(e).__name__
    print(json.dumps(out))


if __name__ == "__main__":
    main()
