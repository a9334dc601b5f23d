"""An independent ROS 2 Imu publisher: Eclipse Cyclone DDS (PyPI `cyclonedds`) writing
`sensor_msgs/msg/Imu` (DDS type `sensor_msgs::msg::dds_::Imu_`, declared here field by field
from the ROS 2 definition) on a DDS topic such as `rt/imu/data`, reliable + volatile + keep
all, XCDR1 (plain CDR, as rmw_cyclonedds_cpp and rmw_fastrtps_cpp write ROS 2 messages).

Frame: the sensor is mounted level with x east, y north, z up (ENU, REP 103). Like a real
accelerometer it reports the specific force: at rest z reads +g (REP 145), so with
--gravity add, z = a_up + 9.80665 m/s^2.

Usage:
  cyclone_imu.py --topic T record --at2 H.AT2 --azimuth DEG [--vertical V.AT2] [--gravity add|none]
      Publishes one message per sample of the PEER NGA record H.AT2 (values in g, read here;
      horizontal component along azimuth DEG, clockwise from north) at the record's sample
      rate, paced by the monotonic clock: x = a_h sin(DEG), y = a_h cos(DEG), z = a_up (+ g).
      header.stamp of sample i = t0 + i * DT exactly (t0 = the wall clock at the first sample).
  cyclone_imu.py --topic T hostile --good N --rate HZ
      Writes, on the same topic and type name, messages whose layout is not sensor_msgs/Imu
      (one each: a truncated struct, a header whose frame_id is not UTF-8, a frame_id
      claiming 4 GiB), then one well-formed Imu with a NaN acceleration, then N well-formed
      Imu messages at rest at HZ.

Prints one JSON object per line: {"matched": ...} once every writer has matched a reader,
{"sent": ..., "first_stamp_ns": ..., "rate_hz": ...} and {"acked": true|false}.
Exit status 2 if no reader matches within --wait-s (default 30).
"""
import json
import math
import re
import sys
import time

from cyclone_common import Header, Time, domain_id, struct  # first: sets CYCLONEDDS_URI
from cyclonedds.core import Policy, Qos  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.idl import types as t  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from cyclonedds.util import duration  # noqa: E402

STANDARD_GRAVITY_MPS2 = 9.80665
IMU_TYPE = "sensor_msgs::msg::dds_::Imu_"

# geometry_msgs/Quaternion, geometry_msgs/Vector3, sensor_msgs/Imu.
Quaternion = struct("Quaternion", "geometry_msgs::msg::dds_::Quaternion_",
                    [("x", t.float64), ("y", t.float64), ("z", t.float64), ("w", t.float64)])
Vector3 = struct("Vector3", "geometry_msgs::msg::dds_::Vector3_",
                 [("x", t.float64), ("y", t.float64), ("z", t.float64)])
Imu = struct("Imu", IMU_TYPE, [
    ("header", Header),
    ("orientation", Quaternion),
    ("orientation_covariance", t.array[t.float64, 9]),
    ("angular_velocity", Vector3),
    ("angular_velocity_covariance", t.array[t.float64, 9]),
    ("linear_acceleration", Vector3),
    ("linear_acceleration_covariance", t.array[t.float64, 9]),
])

# Wrong layouts under the same type name.
ImuTruncated = struct("ImuTruncated", IMU_TYPE, [("header", Header), ("orientation", Quaternion)])
ImuBadUtf8 = struct("ImuBadUtf8", IMU_TYPE, [
    ("sec", t.int32), ("nanosec", t.uint32), ("frame_id_len", t.uint32),
    ("frame_id", t.array[t.uint8, 4]), ("rest", t.array[t.float64, 37]),
])
ImuHugeString = struct("ImuHugeString", IMU_TYPE, [
    ("sec", t.int32), ("nanosec", t.uint32), ("frame_id_len", t.uint32),
    ("rest", t.array[t.float64, 4]),
])

QOS = Qos(
    Policy.Reliability.Reliable(max_blocking_time=duration(seconds=1)),
    Policy.Durability.Volatile,
    Policy.History.KeepAll,
    Policy.DataRepresentation(use_cdrv0_representation=True),
)


# What most Imu drivers publish with (the ROS 2 sensor-data profile): best effort, keep last 5.
QOS_BEST_EFFORT = Qos(
    Policy.Reliability.BestEffort,
    Policy.Durability.Volatile,
    Policy.History.KeepLast(5),
    Policy.DataRepresentation(use_cdrv0_representation=True),
)


def arg(args, name, default=None):
    if name in args:
        return args[args.index(name) + 1]
    if default is None:
        print(json.dumps({"error": "missing " + name}), flush=True)
        sys.exit(2)
    return default


def read_at2(path):
    """(dt_s, values in g) of a PEER NGA AT2 file: 4 header lines, NPTS and DT on the 4th."""
    with open(path) as f:
        lines = f.read().splitlines()
    m = re.search(r"NPTS=\s*(\d+),\s*DT=\s*([0-9.Ee+-]+)", lines[3])
    npts, dt = int(m.group(1)), float(m.group(2))
    values = [float(v) for line in lines[4:] for v in line.split()]
    assert len(values) == npts, (path, len(values), npts)
    return dt, values


def stamp(ns):
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def imu(stamp_ns, x, y, z):
    """A level ENU Imu sample: no orientation estimate (orientation_covariance[0] = -1, REP 145),
    no rotation, typical MEMS covariances."""
    return Imu(
        header=Header(stamp=stamp(stamp_ns), frame_id="imu_link"),
        orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=[-1.0] + [0.0] * 8,
        angular_velocity=Vector3(x=0.0, y=0.0, z=0.0),
        angular_velocity_covariance=[1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 1e-4],
        linear_acceleration=Vector3(x=x, y=y, z=z),
        linear_acceleration_covariance=[1e-3, 0, 0, 0, 1e-3, 0, 0, 0, 1e-3],
    )


def wait_matched(writers, wait_s):
    deadline = time.monotonic() + wait_s
    while not all(w.get_matched_subscriptions() for w in writers):
        if time.monotonic() > deadline:
            print(json.dumps({"error": "no reader matched within %g s" % wait_s}), flush=True)
            sys.exit(2)
        time.sleep(0.02)
    print(json.dumps({"matched": len(writers)}), flush=True)


def paced(writer, samples, rate_hz):
    """Writes samples[i] = (x, y, z) at t_start + i / rate_hz (monotonic clock, no drift)."""
    t0_ns = time.time_ns()
    period_ns = round(1e9 / rate_hz)
    start = time.monotonic()
    for i, (x, y, z) in enumerate(samples):
        delay = start + i / rate_hz - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        writer.write(imu(t0_ns + i * period_ns, x, y, z))
    print(json.dumps({"sent": len(samples), "first_stamp_ns": t0_ns, "rate_hz": rate_hz}),
          flush=True)


def main():
    args = sys.argv[1:]
    topic_name = arg(args, "--topic")
    wait_s = float(arg(args, "--wait-s", "30"))
    dp = DomainParticipant(domain_id())
    writers = []
    if "record" in args:
        dt, h_g = read_at2(arg(args, "--at2"))
        vertical = arg(args, "--vertical", "")
        v_g = read_at2(vertical)[1] if vertical else [0.0] * len(h_g)
        assert len(v_g) == len(h_g)
        azimuth = math.radians(float(arg(args, "--azimuth")))
        gravity = STANDARD_GRAVITY_MPS2 if arg(args, "--gravity", "add") == "add" else 0.0
        samples = [
            (h * STANDARD_GRAVITY_MPS2 * math.sin(azimuth),
             h * STANDARD_GRAVITY_MPS2 * math.cos(azimuth),
             v * STANDARD_GRAVITY_MPS2 + gravity)
            for h, v in zip(h_g, v_g)
        ]
        writer = DataWriter(dp, Topic(dp, topic_name, Imu, qos=QOS), qos=QOS)
        writers.append(writer)
        wait_matched(writers, wait_s)
        paced(writer, samples, 1.0 / dt)
    elif "hostile" in args:
        good = int(arg(args, "--good"))
        rate_hz = float(arg(args, "--rate"))
        kinds = [
            (ImuTruncated, ImuTruncated(header=Header(stamp=stamp(time.time_ns()), frame_id="imu_link"),
                                        orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0))),
            (ImuBadUtf8, ImuBadUtf8(sec=1, nanosec=0, frame_id_len=4,
                                    frame_id=[0xFF, 0xFE, 0xFD, 0x00], rest=[0.0] * 37)),
            (ImuHugeString, ImuHugeString(sec=1, nanosec=0, frame_id_len=0xFFFFFFFF,
                                          rest=[0.0] * 4)),
        ]
        # One participant can hold several types of one name: each gets its own topic entity.
        for cls, _ in kinds:
            writers.append(DataWriter(dp, Topic(dp, topic_name, cls, qos=QOS), qos=QOS))
        writer = DataWriter(dp, Topic(dp, topic_name, Imu, qos=QOS), qos=QOS)
        writers.append(writer)
        wait_matched(writers, wait_s)
        for w, (_, sample) in zip(writers, kinds):
            w.write(sample)
        print(json.dumps({"wrong_layout": len(kinds)}), flush=True)
        writer.write(imu(time.time_ns(), float("nan"), 0.0, STANDARD_GRAVITY_MPS2))
        print(json.dumps({"nan": 1}), flush=True)
        paced(writer, [(0.0, 0.0, STANDARD_GRAVITY_MPS2)] * good, rate_hz)
    elif "at-rest" in args:
        # A best-effort driver: level, at rest (x = y = 0, z = +g), paced at --rate.
        count = int(arg(args, "--count"))
        rate_hz = float(arg(args, "--rate"))
        writer = DataWriter(dp, Topic(dp, topic_name, Imu, qos=QOS_BEST_EFFORT), qos=QOS_BEST_EFFORT)
        writers.append(writer)
        wait_matched(writers, wait_s)
        paced(writer, [(0.0, 0.0, STANDARD_GRAVITY_MPS2)] * count, rate_hz)
    else:
        print(json.dumps({"error": "mode: record, hostile or at-rest"}), flush=True)
        sys.exit(2)
    acked = all(w.wait_for_acks(duration(seconds=10)) for w in writers)
    print(json.dumps({"acked": acked}), flush=True)
    # Acknowledged is not yet taken: the node's DDS reader (RustDDS 0.15.1) drops what it has
    # not taken from a writer that has left, so stay a moment, as `rockwatch replay` does.
    time.sleep(1.0)


if __name__ == "__main__":
    main()
