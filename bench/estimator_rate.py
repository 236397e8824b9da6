"""Estimator node throughput: the highest wrench rate it takes without loss, and its CPU.

    source ./env.sh && python bench/estimator_rate.py [--seconds 2]

Two subscribers, each a separate process, receive the same paced bursts of
WrenchStamped from this process at rising rates: the reference (bench/bare_subscriber.py:
EventsExecutor, raw bytes, counting only; the fastest bare rclpy subscriber, docs/design.md)
and the estimator node. Before a burst each is reset, after it each is asked how many
samples it holds (``~/reset`` answers "cleared N samples"). The lossless rate is the
highest rate below which no burst lost a message. CPU is the process's user + system
time during a 5 s stream at 1 kHz. Targets: node >= 0.9x the reference's lossless rate,
no loss at 5 kHz, < 15 % of a core at 1 kHz.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from com_core.contract import ESTIMATOR_RESET_SERVICE, WRENCH_TOPIC
from com_core.runtime.processes import executable, stop
from com_core.runtime.rosenv import keep_dds_local

RATES = (1000, 2000, 5000, 10000, 15000, 20000, 30000, 40000, 50000, 60000)


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process, s."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


class Bench:
    """Publisher and service client in this process."""

    def __init__(self) -> None:
        import rclpy
        from geometry_msgs.msg import WrenchStamped
        from rclpy.executors import SingleThreadedExecutor

        rclpy.init()
        self.node = rclpy.create_node("estimator_rate_bench")
        self.pub = self.node.create_publisher(WrenchStamped, WRENCH_TOPIC, 1000)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.msg = WrenchStamped()
        self.msg.header.frame_id = "ft_sensor"
        self.msg.wrench.force.z = 9.0
        self.stamp_ns = 1_000_000_000

    def wait_subscribers(self, n: int, timeout: float = 30.0) -> None:
        deadline = time.monotonic() + timeout
        while self.pub.get_subscription_count() < n:
            if time.monotonic() > deadline:
                raise RuntimeError("subscriber never matched")
            time.sleep(0.05)

    def reset(self, service: str) -> int:
        """Call ``service`` (std_srvs/Trigger); the count of samples it cleared."""
        from std_srvs.srv import Trigger

        client = self.node.create_client(Trigger, service)
        if not client.wait_for_service(timeout_sec=30.0):
            raise RuntimeError(f"{service} not available")
        future = client.call_async(Trigger.Request())
        self.executor.spin_until_future_complete(future, timeout_sec=30.0)
        self.node.destroy_client(client)
        return int(re.search(r"cleared (\d+)", future.result().message).group(1))

    def burst(self, rate: float, seconds: float) -> tuple[int, float]:
        """Publish rate * seconds messages, paced every 1 ms; (sent, achieved rate)."""
        n = int(rate * seconds)
        step = round(1e9 / rate)
        start = time.monotonic()
        for i in range(n):
            self.stamp_ns += step
            self.msg.header.stamp.sec, self.msg.header.stamp.nanosec = divmod(
                self.stamp_ns, 1_000_000_000
            )
            self.pub.publish(self.msg)
            if i % 20 == 19:
                lag = start + (i + 1) / rate - time.monotonic()
                if lag > 0:
                    time.sleep(lag)
        return n, n / (time.monotonic() - start)


def lossless_scan(
    rates: Sequence[int], burst: Callable[[int], tuple[int, int, Any]]
) -> tuple[list[Any], int]:
    """Bursts at rising ``rates`` (``burst(rate)`` -> (sent, received, row)) until the
    second lossy one: (the rows, the highest rate below which no burst lost a message)."""
    rows, lossless, failures = [], 0, 0
    for rate in rates:
        sent, got, row = burst(rate)
        rows.append(row)
        if got == sent and failures == 0:
            lossless = rate
        elif got != sent:
            failures += 1
            if failures >= 2:
                break
    return rows, lossless


def measure(bench: Bench, command: list[str], service: str, seconds: float) -> dict:
    proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        bench.wait_subscribers(1)
        bench.reset(service)
        time.sleep(0.5)
        cpu0, t0 = cpu_seconds(proc.pid), time.monotonic()
        bench.burst(1000, 5.0)
        cpu = (cpu_seconds(proc.pid) - cpu0) / (time.monotonic() - t0)
        time.sleep(0.3)
        bench.reset(service)

        def burst(rate: int) -> tuple[int, int, tuple]:
            sent, achieved = bench.burst(rate, seconds)
            time.sleep(0.5)
            got = bench.reset(service)
            return sent, got, (rate, achieved, sent, got)

        rows, lossless = lossless_scan(RATES, burst)
        return {"cpu_1khz": cpu, "rows": rows, "lossless": lossless}
    finally:
        stop(proc)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="burst length per rate")
    args = parser.parse_args()
    keep_dds_local(own_domain=True)
    bench = Bench()
    bare = measure(
        bench,
        [sys.executable, str(Path(__file__).with_name("bare_subscriber.py"))],
        "/bare_subscriber/reset",
        args.seconds,
    )
    node = measure(
        bench,
        [str(executable("com_estimator", "estimator_node"))],
        ESTIMATOR_RESET_SERVICE,
        args.seconds,
    )
    print(f"{'rate Hz':>8} {'sent/s':>8} {'bare got':>9} {'node got':>9} {'sent':>7}")
    for (rate, achieved, sent, got_bare), row in zip(
        bare["rows"], node["rows"] + [None] * 20, strict=False
    ):
        got_node = "-" if row is None else row[3]
        print(f"{rate:8d} {achieved:8.0f} {got_bare:9d} {got_node!s:>9} {sent:7d}")
    ratio = node["lossless"] / bare["lossless"] if bare["lossless"] else float("nan")
    five_khz = next((r for r in node["rows"] if r[0] == 5000), None)
    print(
        f"lossless up to: bare {bare['lossless']} Hz, node {node['lossless']} Hz "
        f"-> node / bare = {ratio:.2f} (target >= 0.9)"
    )
    print(f"loss at 5 kHz: node {five_khz[2] - five_khz[3] if five_khz else 'n/a'} (target 0)")
    print(
        f"CPU at 1 kHz: node {node['cpu_1khz']:.1%} of a core, bare {bare['cpu_1khz']:.1%} "
        f"(target < 15 %)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
