"""Writes hands' BioTac bags with a writer independent of the Rust crates:
Python's rosbags, serialising from the message definitions registered in
its type system (ROS 1 serialization for .bag, CDR in rosbag2 MCAP).

Usage: write_hand_bags.py OUT_DIR

One session of 3 presses, 900 messages at 100 Hz on each topic, the
wrenches stamped up to 2 ms off the readings. Written to OUT_DIR:

- shadow.bag, shadow_mcap/ (rosbag2, MCAP): sr_robot_msgs/BiotacAll
  (Biotac[5] tactiles) on /rh/tactile, WrenchStamped on /ft; shadow_bz2.bag
  and shadow_lz4.bag: the ROS 1 bag with compressed chunks;
- penn.bag, penn_mcap/: biotac_sensors/BioTacHand (3 sensors) on
  /biotac_pub, WrenchStamped on /ft;
- unknown_type.bag: std_msgs/String on /rh/tactile;
- expected.json: per message, the stamp (ns), each sensor's channels and
  the wrench, as written.
"""

import json
import math
import sys
from pathlib import Path

import numpy as np
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

N = 900
START_NS = 1_600_000_000 * 10**9 + 123_000_000
PERIOD_NS = 10_000_000
SHADOW_SENSORS = 5
PENN_SENSORS = 3

# The definitions as the drivers ship them (sr_robot_msgs, biotac_sensors).
BIOTAC = """int16 pac0
int16 pac1
int16 pdc
int16 tac
int16 tdc
int16[] electrodes
"""
BIOTAC_ALL = "std_msgs/Header header\nBiotac[5] tactiles\n"
BIOTAC_DATA = """string bt_serial
uint16 bt_position
uint16 tdc_data
uint16 tac_data
uint16 pdc_data
uint16[22] pac_data
uint16[19] electrode_data
"""
BIOTAC_TIME = """builtin_interfaces/Time frame_start_time
builtin_interfaces/Time frame_end_time
uint32 tdc_ns_offset
uint32 tac_ns_offset
uint32 pdc_ns_offset
uint32[22] pac_ns_offset
uint32[19] electrode_ns_offset
"""
BIOTAC_HAND = """std_msgs/Header header
string hand_id
BioTacData[] bt_data
BioTacTime bt_time
"""


def typestore(store):
    ts = get_typestore(store)
    types = {}
    for name, text in [
        ("sr_robot_msgs/msg/Biotac", BIOTAC),
        ("sr_robot_msgs/msg/BiotacAll", BIOTAC_ALL),
        ("biotac_sensors/msg/BioTacData", BIOTAC_DATA),
        ("biotac_sensors/msg/BioTacTime", BIOTAC_TIME),
        ("biotac_sensors/msg/BioTacHand", BIOTAC_HAND),
    ]:
        if store == Stores.ROS1_NOETIC:
            text = text.replace("builtin_interfaces/Time", "time")
        types.update(get_types_from_msg(text, name))
    ts.register(types)
    return ts


def force(i):
    """Three presses along -z of the F/T sensor, rests between them."""
    t = i / 100.0
    f = 0.0
    for start in (1.5, 4.5, 7.0):
        if start <= t < start + 1.5:
            f = 1.0 + 0.5 * math.sin(3.0 * (t - start))
    return [0.08 + 0.01 * f, -0.04 - 0.02 * f, -0.18 - f]


def sensor(i, k):
    """Channels of sensor k in message i (counts)."""
    press = -force(i)[2] - 0.18
    electrodes = [int(3000 - 100 * k - 20 * e - 300 * press * (e % 3)) for e in range(19)]
    return {
        "electrodes": electrodes,
        "pdc": int(1970 + 10 * k + 150 * press),
        "tdc": 2360 + k,
        "tac": 2000 + (i % 7) + k,
        "pac": [2040 + ((i + j + k) % 9) for j in range(22)],
    }


def stamp(ts, ns):
    return ts.types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)


def header(ts, ros1, ns, seq):
    h = ts.types["std_msgs/msg/Header"]
    if ros1:
        return h(seq=seq, stamp=stamp(ts, ns), frame_id="hand")
    return h(stamp=stamp(ts, ns), frame_id="hand")


def shadow_msg(ts, ros1, i, ns):
    biotac = ts.types["sr_robot_msgs/msg/Biotac"]
    tactiles = []
    for k in range(SHADOW_SENSORS):
        s = sensor(i, k)
        tactiles.append(
            biotac(
                pac0=s["pac"][0],
                pac1=s["pac"][1],
                pdc=s["pdc"],
                tac=s["tac"],
                tdc=s["tdc"],
                electrodes=np.array(s["electrodes"], dtype=np.int16),
            )
        )
    return ts.types["sr_robot_msgs/msg/BiotacAll"](header=header(ts, ros1, ns, i), tactiles=tactiles)


def penn_msg(ts, ros1, i, ns):
    data = ts.types["biotac_sensors/msg/BioTacData"]
    bt = []
    for k in range(PENN_SENSORS):
        s = sensor(i, k)
        bt.append(
            data(
                bt_serial=f"B1234{k}",
                bt_position=k,
                tdc_data=s["tdc"],
                tac_data=s["tac"],
                pdc_data=s["pdc"],
                pac_data=np.array(s["pac"], dtype=np.uint16),
                electrode_data=np.array(s["electrodes"], dtype=np.uint16),
            )
        )
    t = stamp(ts, ns)
    bt_time = ts.types["biotac_sensors/msg/BioTacTime"](
        frame_start_time=t,
        frame_end_time=t,
        tdc_ns_offset=0,
        tac_ns_offset=0,
        pdc_ns_offset=0,
        pac_ns_offset=np.zeros(22, dtype=np.uint32),
        electrode_ns_offset=np.zeros(19, dtype=np.uint32),
    )
    return ts.types["biotac_sensors/msg/BioTacHand"](
        header=header(ts, ros1, ns, i), hand_id="left", bt_data=bt, bt_time=bt_time
    )


def wrench_msg(ts, ros1, i, ns):
    v3 = ts.types["geometry_msgs/msg/Vector3"]
    f = force(i)
    w = ts.types["geometry_msgs/msg/Wrench"](
        force=v3(x=f[0], y=f[1], z=f[2]), torque=v3(x=0.001 * i, y=-0.002, z=0.003)
    )
    return ts.types["geometry_msgs/msg/WrenchStamped"](header=header(ts, ros1, ns, i), wrench=w)


def jitter_ns(i):
    return ((i * 7919) % 5 - 2) * 1_000_000


def write(path, ros1, hand_type, topic, make, compression=None):
    ts = typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    wrench_type = "geometry_msgs/msg/WrenchStamped"
    serialize = ts.serialize_ros1 if ros1 else ts.serialize_cdr
    writer = Writer1(path) if ros1 else Writer2(path, version=8, storage_plugin=StoragePlugin.MCAP)
    if compression is not None:
        writer.set_compression(compression)
    with writer:
        hand = writer.add_connection(topic, hand_type, typestore=ts)
        ft = writer.add_connection("/ft", wrench_type, typestore=ts)
        for i in range(N):
            ns = START_NS + i * PERIOD_NS
            writer.write(hand, ns, serialize(make(ts, ros1, i, ns), hand_type))
            wns = ns + jitter_ns(i)
            writer.write(ft, wns, serialize(wrench_msg(ts, ros1, i, wns), wrench_type))


def main():
    out = Path(sys.argv[1])
    for ros1 in (True, False):
        shadow = out / ("shadow.bag" if ros1 else "shadow_mcap")
        penn = out / ("penn.bag" if ros1 else "penn_mcap")
        write(shadow, ros1, "sr_robot_msgs/msg/BiotacAll", "/rh/tactile", shadow_msg)
        write(penn, ros1, "biotac_sensors/msg/BioTacHand", "/biotac_pub", penn_msg)
    for name, fmt in [("bz2", Writer1.CompressionFormat.BZ2), ("lz4", Writer1.CompressionFormat.LZ4)]:
        path = out / f"shadow_{name}.bag"
        write(path, True, "sr_robot_msgs/msg/BiotacAll", "/rh/tactile", shadow_msg, fmt)

    ts = typestore(Stores.ROS1_NOETIC)
    with Writer1(out / "unknown_type.bag") as w:
        c = w.add_connection("/rh/tactile", "std_msgs/msg/String", typestore=ts)
        for i in range(10):
            w.write(c, START_NS + i * PERIOD_NS, ts.serialize_ros1(ts.types["std_msgs/msg/String"](data="x"), "std_msgs/msg/String"))

    expected = []
    for i in range(N):
        ns = START_NS + i * PERIOD_NS
        expected.append(
            {
                "stamp_ns": ns,
                "sensors": [sensor(i, k) for k in range(SHADOW_SENSORS)],
                "force": force(i),
                "torque": [0.001 * i, -0.002, 0.003],
            }
        )
    (out / "expected.json").write_text(json.dumps(expected))


if __name__ == "__main__":
    main()
