"""CLI: the ``import`` group; ``import rosbag`` converts JointState messages into a log (docs/rosbag.md)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from torquemap.cli.helptext import described
from torquemap.cli.outputs import check_table


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add the ``import`` group and its ``rosbag`` sub-command."""
    group = subparsers.add_parser(
        "import",
        help="convert recordings into torquemap logs",
        **described(
            "Convert recordings made with other tools into the log format of docs/formats.md "
            "(t, q_<j>, tau_<j> or i_<j>). KIND names the recording: rosbag (ROS 1 and ROS 2 "
            "bags, docs/rosbag.md).",
            ["torquemap import rosbag run.bag --robot robot.toml -o run.parquet"],
        ),
    )
    kinds = group.add_subparsers(dest="kind", metavar="KIND", help="the kind of recording")
    kinds.required = True
    p = kinds.add_parser(
        "rosbag",
        help="sensor_msgs/JointState from a ROS 1 bag or a ROS 2 bag (sqlite3 or MCAP)",
        **described(
            "Convert the sensor_msgs/JointState messages of one topic into the log format "
            "(t, q_<j>, tau_<j> or i_<j>); no ROS installation needed. t counts from the first "
            "kept message's header stamp (docs/rosbag.md).",
            [
                "torquemap import rosbag run.bag --robot robot.toml -o run.parquet",
                "torquemap import rosbag rosbag2_run/ --robot robot.toml -o run.csv "
                "--topic /arm/joint_states --map shoulder_joint=a --map elbow_joint=b",
            ],
        ),
    )
    p.add_argument("bag", metavar="BAG", help="ROS 1 .bag file or ROS 2 bag folder")
    p.add_argument(
        "--robot", metavar="ROBOT.toml", required=True, help="robot file: the joints to keep"
    )
    p.add_argument("--topic", default="/joint_states", help="JointState topic (/joint_states)")
    p.add_argument(
        "-o",
        "--output",
        metavar="LOG.parquet",
        required=True,
        help="log to write: .parquet or .csv (the suffix chooses the format)",
    )
    p.add_argument(
        "--map",
        metavar="NAME=JOINT",
        action="append",
        default=None,
        help="message joint NAME is robot joint JOINT (repeat; default: same names)",
    )
    p.add_argument(
        "--effort",
        choices=("torque", "current"),
        default="torque",
        help="effort is the joint-side torque [N m] (ROS convention; divided by the gear ratio "
        "into tau_<j>) or the motor current [A] (into i_<j>)",
    )
    p.set_defaults(handler=_rosbag)


def _rosbag(args: argparse.Namespace) -> int:
    from torquemap.cli.outputs import TABLE, check_outputs
    from torquemap.robot import load_robot
    from torquemap.rosbag import import_rosbag

    check_table(args.output, (".parquet", ".csv"))
    check_outputs([(args.output, TABLE)], [args.bag, args.robot])
    robot = load_robot(args.robot)
    states = args.progress.run(
        f"read {args.topic} from the bag",
        lambda: import_rosbag(
            args.bag, robot, args.topic, args.output, mapping=args.map, effort=args.effort
        ),
    )
    if states.skipped:
        print(
            f"torquemap: warning: {states.skipped} messages on {args.topic} lacked a robot joint "
            "and were skipped",
            file=sys.stderr,
        )
    if states.other_publishers:
        dropped = ", ".join(f"{name}'s {n}" for name, n in states.other_publishers)
        print(
            f"torquemap: warning: more than one publisher on {args.topic} sends every joint: "
            f"read the {states.t.size + states.duplicates} messages of the one with the most, "
            f"dropped {dropped} (merged, their readings would be out of step: a relay's copies "
            "or a second driver)",
            file=sys.stderr,
        )
    if states.unwrapped:
        print(
            f"torquemap: note: {', '.join(states.unwrapped)}: positions wrapped to one turn "
            "(continuous joints as ROS publishes them) were unwrapped: whole turns added where "
            "they jumped by 2 pi between two messages",
            file=sys.stderr,
        )
    if states.duplicates:
        print(
            f"torquemap: warning: {states.duplicates} messages repeated the previous stamp and "
            "were dropped",
            file=sys.stderr,
        )
    print(
        f"wrote {args.output}: {states.t.size} samples over {states.t[-1]:.6g} s from "
        f"{args.topic} (first stamp {states.start_ns // 10**9}.{states.start_ns % 10**9:09d} s)"
    )
    return 0
