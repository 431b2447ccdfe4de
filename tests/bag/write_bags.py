"""Writes rosbag2-style MCAP files from a training CSV, with an MCAP writer
independent of the Rust crate: mcap-ros2-support serialises each message
from its .msg definition.

Usage: write_bags.py SESSION_CSV BIOTAC_MSG OUT_DIR

The CSV is one `tactile_force collect` file (t,set,trial,e1..e19,pdc,
pac_mean,tdc,tac,fx,fy,fz,tx,ty,tz). Its rows become one session at 100 Hz:
a BioTac reading and an F/T WrenchStamped per row, the wrench stamped up to
2 ms off the reading. Written to OUT_DIR:

- good.mcap: every row, both topics;
- truncated.mcap: good.mcap cut in half;
- wrong_type.mcap: the F/T topic carries geometry_msgs/msg/Wrench;
- no_ft.mcap: no F/T topic;
- clock_jump.mcap: the BioTac stamps step back 5 s half-way.
"""

import csv
import random
import sys
from pathlib import Path

from mcap_ros2.writer import Writer

BIOTAC_TOPIC = "/biotac/readings"
FT_TOPIC = "/ft_sensor/wrench"
START_NS = 1_700_000_000 * 10**9
PERIOD_NS = 10_000_000
JITTER_NS = 2_000_000
N_ELECTRODES = 19
N_PAC = 22

SEPARATOR = "=" * 80

# The dependencies of a message, each after a separator line and a
# `MSG: package/Name` line, as rosbag2 stores a schema.
TIME = "int32 sec\nuint32 nanosec\n"
HEADER = "builtin_interfaces/Time stamp\nstring frame_id\n"
VECTOR3 = "float64 x\nfloat64 y\nfloat64 z\n"
WRENCH = "Vector3 force\nVector3 torque\n"
WRENCH_STAMPED = "std_msgs/Header header\nWrench wrench\n"


def schema_text(main, *deps):
    """A message definition followed by its dependencies (name, text)."""
    parts = [main]
    for name, text in deps:
        parts.append(f"{SEPARATOR}\nMSG: {name}\n{text}")
    return "\n".join(parts)


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def stamp(ns):
    return {"sec": ns // 10**9, "nanosec": ns % 10**9}


def biotac_msg(row, i, stamp_ns):
    return {
        "header": {"stamp": stamp(stamp_ns), "frame_id": "biotac"},
        "serial": "",
        "sensor_index": 0,
        "seq": i % 65536,
        "electrodes": [int(row[f"e{k}"]) for k in range(1, N_ELECTRODES + 1)],
        "pdc": int(row["pdc"]),
        "pac": [round(float(row["pac_mean"]))] * N_PAC,
        "tdc": int(row["tdc"]),
        "tac": int(row["tac"]),
        "invalid_channels": [],
    }


def wrench(row):
    def vec(a, b, c):
        return {"x": float(row[a]), "y": float(row[b]), "z": float(row[c])}

    return {"force": vec("fx", "fy", "fz"), "torque": vec("tx", "ty", "tz")}


def write(path, rows, biotac_def, ft=None, jump_at=None):
    """One bag: the readings, and the F/T topic as (type, definition,
    message of a row and its stamp) unless None. From row `jump_at` on the
    reading stamps are 5 s earlier."""
    rng = random.Random(7)
    with open(path, "wb") as f, Writer(f) as w:
        biotac = w.register_msgdef("tactile_force_msgs/msg/BioTac", biotac_def)
        ft_schema = ft and w.register_msgdef(ft[0], ft[1])
        for i, row in enumerate(rows):
            stamp_ns = START_NS + i * PERIOD_NS
            if jump_at is not None and i >= jump_at:
                stamp_ns -= 5 * 10**9
            # Logged 1 ms after the stamp, as a recorder receives it.
            w.write_message(
                BIOTAC_TOPIC,
                biotac,
                biotac_msg(row, i, stamp_ns),
                log_time=START_NS + i * PERIOD_NS + 1_000_000,
            )
            if ft_schema:
                ft_ns = START_NS + i * PERIOD_NS + rng.randint(-JITTER_NS, JITTER_NS)
                w.write_message(
                    FT_TOPIC, ft_schema, ft[2](row, ft_ns), log_time=ft_ns + 1_000_000
                )


def main():
    csv_path, msg_path, out = sys.argv[1:]
    out = Path(out)
    rows = read_rows(csv_path)
    biotac_def = schema_text(
        Path(msg_path).read_text(),
        ("std_msgs/Header", HEADER),
        ("builtin_interfaces/Time", TIME),
    )
    stamped_def = schema_text(
        WRENCH_STAMPED,
        ("std_msgs/Header", HEADER),
        ("builtin_interfaces/Time", TIME),
        ("geometry_msgs/Wrench", WRENCH),
        ("geometry_msgs/Vector3", VECTOR3),
    )
    stamped = (
        "geometry_msgs/msg/WrenchStamped",
        stamped_def,
        lambda row, ns: {
            "header": {"stamp": stamp(ns), "frame_id": "ft_sensor"},
            "wrench": wrench(row),
        },
    )
    unstamped = (
        "geometry_msgs/msg/Wrench",
        schema_text(WRENCH, ("geometry_msgs/Vector3", VECTOR3)),
        lambda row, _ns: wrench(row),
    )

    good = out / "good.mcap"
    write(good, rows, biotac_def, stamped)
    data = good.read_bytes()
    (out / "truncated.mcap").write_bytes(data[: len(data) // 2])
    write(out / "wrong_type.mcap", rows, biotac_def, unstamped)
    write(out / "no_ft.mcap", rows, biotac_def)
    write(out / "clock_jump.mcap", rows, biotac_def, stamped, jump_at=len(rows) // 2)
    print(f"{len(rows)} rows -> {out}/good.mcap ({len(data)} bytes) and 4 bad bags")


if __name__ == "__main__":
    main()
