"""Publishes acceleration packets (a JSON list) on rockwatch's pbr/accel over iceoryx2.

usage: accel_publisher.py CONFIG_FILE SERVICE PACKETS_JSON [--pause-after N] [--linger]
Each packet: {station, start_time_ns, sample_rate_hz, sequence, east, north, up}. With
--pause-after N it prints "paused" after N packets and sleeps (to be killed); with --linger it
waits for stdin to close before exiting.
"""

import ctypes
import json
import sys
import time

import iceoryx2 as iox

from rockwatch_iox import ACCEL_FLAG_HAS_UP, AccelHeader, AccelSample, accel_service, event_service, node, padded


def main() -> None:
    config_file, name, packets_file = sys.argv[1:4]
    pause_after = int(sys.argv[5]) if len(sys.argv) > 5 and sys.argv[4] == "--pause-after" else None
    with open(packets_file) as f:
        packets = json.load(f)
    n = node(config_file)
    service = accel_service(n, name)
    publisher = (
        service.publisher_builder()
        .initial_max_slice_len(256)
        .allocation_strategy(iox.AllocationStrategy.PowerOfTwo)
        .create()
    )
    notifier = event_service(n, name).notifier_builder().create()
    deadline = time.monotonic() + 20
    while service.dynamic_config.number_of_subscribers == 0:
        if time.monotonic() > deadline:
            sys.exit("no subscriber on " + name)
        time.sleep(0.01)
    for i, p in enumerate(packets):
        count = len(p["east"])
        has_up = len(p["up"]) == count
        sample = publisher.loan_slice_uninit(count)
        header = AccelHeader(
            station=padded(p["station"], 16),
            sample_rate_hz=p["sample_rate_hz"],
            start_time_ns=p["start_time_ns"],
            sequence=p["sequence"],
            sample_count=count,
            flags=ACCEL_FLAG_HAS_UP if has_up else 0,
            reserved=0,
        )
        ctypes.memmove(sample.user_header_ptr, ctypes.byref(header), ctypes.sizeof(header))
        values = (AccelSample * count)(
            *(
                AccelSample(p["east"][k], p["north"][k], p["up"][k] if has_up else 0.0)
                for k in range(count)
            )
        )
        # Written through the raw pointer: Slice.len() of iceoryx2 0.10.0 returns bytes, not
        # elements (#1533), so the slice is never sized by len().
        ctypes.memmove(sample.payload_ptr, values, ctypes.sizeof(values))
        sample.assume_init().send()
        notifier.notify()
        if pause_after is not None and i + 1 == pause_after:
            print("paused", flush=True)
            time.sleep(60)
    print("sent", len(packets), flush=True)
    # Stay connected until told (stdin closed, bounded): samples of a publisher that is gone
    # are kept only in the subscriber's expired-connection buffer.
    if "--linger" in sys.argv:
        sys.stdin.readline()


if __name__ == "__main__":
    main()
