"""Runs `rockwatch node` with its stderr on a one-page pipe that nobody reads while a replay
runs, then reads it. Prints REPLAY_RC=, NODE_RC=; writes the node's stderr to NODE_ERR.

usage: blocked_stderr.py ROCKWATCH NODE_CONFIG RECORD NODE_ERR REPLAY_ERR
"""
import fcntl
import os
import subprocess
import sys
import time

F_SETPIPE_SZ = 1031  # Linux fcntl: the pipe's capacity (at least one page)

bin_, config, record, node_err, replay_err = sys.argv[1:6]
r, w = os.pipe()
fcntl.fcntl(w, F_SETPIPE_SZ, 4096)
node = subprocess.Popen(
    [bin_, "node", "--config", config, "--log-level", "debug"], stderr=w
)
os.close(w)
with open(replay_err, "w") as err:
    rc = subprocess.call(
        [bin_, "replay", "--config", config, "--record", record, "--azimuth", "228",
         "--station", "CI.RRS.00", "--transport", "ros2", "--speed", "max", "--tail", "5",
         "--wait-s", "30"],
        stdout=subprocess.DEVNULL, stderr=err,
    )
print(f"REPLAY_RC={rc}", flush=True)
node.terminate()
os.set_blocking(r, False)
data = bytearray()
deadline = time.time() + 30
while time.time() < deadline:
    try:
        chunk = os.read(r, 65536)
        if not chunk and node.poll() is not None:
            break
        data += chunk
    except BlockingIOError:
        if node.poll() is not None:
            break
        time.sleep(0.02)
if node.poll() is None:
    node.kill()
print(f"NODE_RC={node.wait()}", flush=True)
with open(node_err, "wb") as f:
    f.write(bytes(data))
