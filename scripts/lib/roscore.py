#!/usr/bin/env python3
"""A roscore of our own on a free port, the one way the scripts start one (scripts/demo,
scripts/bench_node.py). As a program: `roscore.py LOG_DIR` starts it in a session of its own,
waits until it answers and prints "PORT PID" (stop it by killing that process group)."""

import os
import socket
import subprocess
import sys
import time
import xmlrpc.client


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def start(log_dir, timeout=20.0):
    """Starts roscore on a free port (log in LOG_DIR/roscore.log); returns (process, port) once
    the master answers. Raises RuntimeError if it does not within `timeout` seconds."""
    os.makedirs(log_dir, exist_ok=True)
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:%d" % port, ROS_LOG_DIR=log_dir)
    env.setdefault("ROS_HOME", log_dir)
    process = subprocess.Popen(["roscore", "-p", str(port)], env=env, start_new_session=True,
                               stdout=open(os.path.join(log_dir, "roscore.log"), "w"),
                               stderr=subprocess.STDOUT)
    master = xmlrpc.client.ServerProxy("http://127.0.0.1:%d" % port)
    deadline = time.time() + timeout
    while True:
        try:
            master.getPid("/roscore_py")
            return process, port
        except OSError:
            pass
        if process.poll() is not None or time.time() > deadline:
            stop(process)
            raise RuntimeError("roscore did not start (see %s/roscore.log)" % log_dir)
        time.sleep(0.2)


def stop(process):
    """SIGINT to its process group, then SIGKILL after 5 s."""
    if process is None or process.poll() is not None:
        return
    try:
        os.killpg(process.pid, 2)
        process.wait(timeout=5)
    except (OSError, subprocess.TimeoutExpired):
        try:
            os.killpg(process.pid, 9)
        except OSError:
            pass


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: roscore.py LOG_DIR")
    try:
        core, core_port = start(sys.argv[1])
    except RuntimeError as e:
        sys.exit("roscore.py: %s" % e)
    print("%d %d" % (core_port, core.pid))
