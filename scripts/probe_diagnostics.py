"""Wait until a running pmr_diagnostician reports on /diagnostics; exit 0 when it did.

Used by scripts/check_colcon_install.sh to tell that a started node is not only
alive but working: with no r, u or y to listen to, the diagnostician reports
its signals STALE after ``diagnostician.stale_timeout_s`` (5 s by default), so
a report proves it read its parameters and its topic contract.  Plain rclpy
only (no pmr_ros import), so it checks the node and not this script's copy of
the package.

    usage: python scripts/probe_diagnostics.py [--prefix pmr/wood_berry/] [--timeout 30]

Exit status: 0 with the report's first status on one line; 1 with one line
saying what was missing when nothing came in time.
"""

from __future__ import annotations

import argparse
import sys
import time


def main(argv: list[str] | None = None) -> int:
    """Subscribe to /diagnostics and wait for a status whose name starts with ``--prefix``.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments (``sys.argv[1:]`` by default).

    Returns
    -------
    int
        The exit status.
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--prefix", default="pmr/", help="what the statuses' names start with (pmr/<namespace>/<system>/<element>)"
    )
    parser.add_argument("--timeout", type=float, default=30.0, help="seconds to wait")
    args = parser.parse_args(argv)

    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    # The contract's QoS of /diagnostics (msg_defs/topics.yaml): reliable, transient local, depth 10,
    # so a report sent before this subscriber matched still arrives.
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    rclpy.init(args=[])
    try:
        node = rclpy.create_node("pmr_ros_install_probe")
        reports: list[DiagnosticArray] = []
        node.create_subscription(DiagnosticArray, "/diagnostics", reports.append, qos)
        deadline = time.monotonic() + args.timeout
        while time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.2)
            for report in reports:
                statuses = [s for s in report.status if s.name.startswith(args.prefix)]
                if statuses:
                    first = statuses[0]
                    level = (
                        int.from_bytes(first.level, "little") if isinstance(first.level, bytes) else int(first.level)
                    )
                    print(f"{first.name} level {level}: {first.message}")
                    return 0
            reports.clear()
        print(
            f"probe_diagnostics: no status named {args.prefix}... on /diagnostics within {args.timeout:g} s",
            file=sys.stderr,
        )
        return 1
    finally:
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
