"""Prints rockwatch alerts received on pbr/alerts over iceoryx2 as JSON lines.

usage: alert_subscriber.py CONFIG_FILE SERVICE STOP_FILE MAX_SECONDS
Prints "ready" once subscribed; stops when STOP_FILE exists or after MAX_SECONDS.
"""

import json
import os
import sys
import time

import iceoryx2 as iox

from rockwatch_iox import alert_service, event_service, node, unpadded


def main() -> None:
    config_file, name, stop_file, max_s = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])
    n = node(config_file)
    subscriber = alert_service(n, name).subscriber_builder().create()
    listener = event_service(n, name).listener_builder().create()
    print("ready", flush=True)
    deadline = time.monotonic() + max_s
    while time.monotonic() < deadline:
        listener.timed_wait(iox.Duration.from_millis(50))
        while True:
            sample = subscriber.receive()
            if sample is None:
                break
            a = sample.payload().contents
            print(
                json.dumps(
                    {
                        "sequence": a.sequence,
                        "pbr_id": unpadded(a.pbr_id),
                        "station": unpadded(a.station),
                        "level": a.level,
                        "mode": a.mode,
                        "theta_over_alpha": a.theta_over_alpha,
                        "data_time_ns": a.data_time_ns,
                    }
                ),
                flush=True,
            )
        if os.path.exists(stop_file):
            break


if __name__ == "__main__":
    main()
