"""rockwatch's iceoryx2 wire types for Python clients (layouts: docs/iceoryx2.md).

Used by the tests as an independent peer: written from the documented C layout, not generated
from the Rust code. Needs the PyPI package iceoryx2 of the same version as the crate (0.10.0).
"""

import ctypes

import iceoryx2 as iox

ACCEL_FLAG_HAS_UP = 1
# The samples are counts (converted by the station's gain in the node's configuration).
ACCEL_FLAG_COUNTS = 2


class AccelHeader(ctypes.Structure):
    _fields_ = [
        ("station", ctypes.c_uint8 * 16),
        ("sample_rate_hz", ctypes.c_double),
        ("start_time_ns", ctypes.c_int64),
        ("sequence", ctypes.c_uint64),
        ("sample_count", ctypes.c_uint64),
        ("flags", ctypes.c_uint32),
        ("reserved", ctypes.c_uint32),
    ]

    @staticmethod
    def type_name() -> str:
        return "rockwatch::AccelHeader"


class AccelSample(ctypes.Structure):
    _fields_ = [
        ("east", ctypes.c_float),
        ("north", ctypes.c_float),
        ("up", ctypes.c_float),
    ]

    @staticmethod
    def type_name() -> str:
        return "rockwatch::AccelSample"


class PbrAlert(ctypes.Structure):
    _fields_ = [
        ("sequence", ctypes.c_uint64),
        ("data_time_ns", ctypes.c_int64),
        ("latency_ns", ctypes.c_int64),
        ("theta_over_alpha", ctypes.c_double),
        ("slide_m", ctypes.c_double),
        ("overturn_probability", ctypes.c_double),
        ("pga_mps2", ctypes.c_double),
        ("pgv_mps", ctypes.c_double),
        ("episode", ctypes.c_uint32),
        ("flags", ctypes.c_uint32),
        ("level", ctypes.c_uint8),
        ("mode", ctypes.c_uint8),
        ("reserved", ctypes.c_uint8 * 6),
        ("station", ctypes.c_uint8 * 16),
        ("pbr_id", ctypes.c_uint8 * 64),
        ("direction_deg", ctypes.c_double),
    ]

    @staticmethod
    def type_name() -> str:
        return "rockwatch::PbrAlert"


assert ctypes.sizeof(AccelHeader) == 56 and ctypes.alignment(AccelHeader) == 8
assert ctypes.sizeof(AccelSample) == 12 and ctypes.alignment(AccelSample) == 4
assert ctypes.sizeof(PbrAlert) == 168 and ctypes.alignment(PbrAlert) == 8


def padded(text: str, n: int):
    data = text.encode("utf-8")[:n]
    return (ctypes.c_uint8 * n)(*data)


def unpadded(field) -> str:
    return bytes(field).split(b"\0", 1)[0].decode("utf-8", "replace")


def node(config_file: str):
    config = iox.config.from_file(iox.FilePath.new(config_file))
    return iox.NodeBuilder.new().config(config).create(iox.ServiceType.Ipc)


def accel_service(node, name: str):
    # The same settings as the node asks for (rockwatch::iox::IoxConfig defaults).
    return (
        node.service_builder(iox.ServiceName.new(name))
        .publish_subscribe(iox.Slice[AccelSample])
        .user_header(AccelHeader)
        .enable_safe_overflow(True)
        .subscriber_max_buffer_size(1024)
        .max_publishers(64)
        .open_or_create()
    )


def alert_service(node, name: str):
    return (
        node.service_builder(iox.ServiceName.new(name))
        .publish_subscribe(PbrAlert)
        .enable_safe_overflow(True)
        .history_size(128)
        .subscriber_max_buffer_size(128)
        .open_or_create()
    )


def event_service(node, name: str):
    return node.service_builder(iox.ServiceName.new(name)).event().open_or_create()
