"""A peer that tries to drive the vehicle: `python -m tests.sidewalk.intruder [--secure DIR --role R] --connect EP --ns NS`.

It puts `--count` drive commands of speed `--speed` on the simulator's drive key, `--rate` per wall
second, and prints how many it sent; exit 3 when it cannot even connect (no credentials, wrong ones).
"""

from __future__ import annotations

import argparse
import sys
import time

from wire.drive import DriveCommand, encode
from wire.errors import WireError
from wire.flags import add_network_args, network_from_args
from wire.keys import SimKeys
from wire.session import open_session


def main(argv: list[str] | None = None) -> int:
    """Parse flags, connect, put the drive commands; return the exit code."""
    p = argparse.ArgumentParser(prog="python -m tests.sidewalk.intruder")
    p.add_argument("--speed", type=float, default=0.777)
    p.add_argument("--count", type=int, default=100)
    p.add_argument("--rate", type=float, default=50.0)
    add_network_args(p)
    args = p.parse_args(argv)
    net = network_from_args(p, args, who="intruder")
    try:
        s = open_session(net)
        s.wait_connected(timeout=5.0, name="intruder")
    except WireError as exc:
        print(f"refused: {exc}", flush=True)
        return 3
    try:
        key = SimKeys(net.namespace).cmd
        for i in range(args.count):
            s.put(key, encode(DriveCommand(speed=args.speed, curvature=0.0, seq=i + 1)))
            time.sleep(1.0 / args.rate)  # a load pace, not a synchronisation
        print(f"sent {args.count}", flush=True)
    finally:
        s.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
