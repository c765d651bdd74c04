"""fbcc_replay: a recorded session back onto the ROS graph with its timing, or offline.

    fbcc_replay BAG [--rate R] [--topics T [T ...]] [--start S] [--loop]
                    [--wait-for-subscribers S] [--prefix NS] [--ros-args ...]
    fbcc_replay BAG --offline [--params FILE ...] [--namespace NS] [--out DIR]

**Republish** (default): every message of the bag (or of ``--topics``) is published as it was
recorded, raw, at its recorded time from the first one, scaled by ``1 / rate``; ``--start``
skips the first S seconds, ``--loop`` starts again at the end. Before the first message it
waits 0.5 s for discovery, or with ``--wait-for-subscribers S`` until every topic has a matched
subscriber (at most S seconds; a topic still unheard then is named). Each topic is offered with the
QoS it was recorded with (transient local where the recorded publisher was latched, so a late
subscriber still gets the last phase). Progress is printed each second; Ctrl-C stops.

**Never live by accident.** The replay publishes under ``--prefix`` (``/replay`` by default:
``/replay/joint_states``), where no cell listens. ``--prefix /`` publishes onto the recorded
names, and then: the arm's commands and the controller's phase (:data:`NEVER_LIVE`) are not
published at all (a replayed joint command moved a live arm 4 mm, a replayed phase said
"inserted" beside a controller in fault); a topic that has a publisher of the live graph
refuses the replay before the first message (exit 2, naming the publishers); and a publisher
that appears while it runs stops it (exit 1).

**Offline** (``--offline``): the bag's joint states and the compensation's input (the raw
wrench, or a virtual sensor's joint torques) run through the compensation, kinematics and
controller core, without ROS (:mod:`fbcc_ros.bag.offline`), with the nodes' parameters from
``--params`` files or the bag's ``fbcc_params.yaml``, the cell's topics under the namespace of
its ``joint_states`` (or ``--namespace``). It prints the
largest difference from the recorded commands, per feature, against the stated tolerance
(:data:`TOLERANCE`), and with ``--out`` writes ``offline.csv`` and ``offline.json``. Changed
parameters (another law, other gains) then show what they would have commanded.

Exit status: 0 done; 1 offline, when the commands of unchanged parameters are not reproduced,
or live, when a live publisher appeared on a replayed topic;
2 bad input (a missing file, a file that is not mcap, a bag without the needed topics, a bad
option), with one line saying what and no traceback.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from fbcc_ros.bag.reader import Bag, read_bag
from fbcc_ros.core.contact.model import FEATURE_NAMES
from fbcc_ros.core.errors import InputError, command
from fbcc_ros.ros import topics

#: Offline replay of a bag with its own parameters reproduces its commands within this, in m
#: (offsets, depth) and rad (tilts): float rounding only. The committed test bag replays to
#: ~1e-16; what exceeds this is a change of behaviour, not noise.
TOLERANCE = 1e-12


#: Where the replay publishes by default: a namespace no cell listens in.
PREFIX = "/replay"
#: How long the live graph is looked at before the first message [s], and how often after it.
#: A fresh process found a running node's publisher in 0.12-3.12 s here (17 tries): DDS's
#: participants announce themselves every 3 s once their first announcements are past.
DISCOVERY = 4.0
LOOK_PERIOD = 0.05
#: What is never published onto the recorded names (``--prefix /``): the arm's commands (ours,
#: the LBR stack's) and the controller's phase.
NEVER_LIVE = (topics.JOINT_COMMAND, topics.LBR_COMMAND, topics.COMMAND, topics.TCP_COMMAND,
              topics.PHASE)  # fmt: skip


def never_live(topic: str) -> bool:
    """Whether the bag's ``topic`` (under any namespace) is one of :data:`NEVER_LIVE`."""
    return any(topic == f"/{name}" or topic.endswith(f"/{name}") for name in NEVER_LIVE)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="fbcc_replay", description=__doc__.splitlines()[0])
    parser.add_argument("bag", type=Path, help="bag folder or .mcap file")
    parser.add_argument("--rate", type=float, default=1.0, help="speed factor (default 1)")
    parser.add_argument("--topics", nargs="+", default=None, help="only these topics")
    parser.add_argument("--start", type=float, default=0.0, help="skip the first S seconds")
    parser.add_argument("--loop", action="store_true", help="start again at the end")
    parser.add_argument("--prefix", default=PREFIX, metavar="NS",
                        help=f"publish under this namespace (default {PREFIX}); '/' onto the "
                        "recorded names: then never the commands nor the phase, and not onto "
                        "a topic with a live publisher")  # fmt: skip
    parser.add_argument(
        "--wait-for-subscribers",
        type=float,
        default=None,
        metavar="S",
        help="before the first message, wait up to S seconds until every topic has a "
        "subscriber (default: wait 0.5 s for discovery)",
    )
    parser.add_argument(
        "--offline",
        action="store_true",
        help="through the core without ROS, against the recorded commands",
    )
    parser.add_argument(
        "--params",
        type=Path,
        nargs="+",
        default=(),
        help="ros__parameters YAML files of the nodes (offline; default: the "
        "bag's fbcc_params.yaml)",
    )
    parser.add_argument("--namespace", default=None, metavar="NS",
                        help="offline: the cell's namespace in the bag (default: that of its "
                        "one joint_states)")  # fmt: skip
    parser.add_argument("--out", type=Path, default=None, help="folder for the offline results")
    return parser  # fmt: skip


def schedule(bag: Bag, topics: list[str] | None, start: float) -> list[Any]:
    """The messages to publish, in recorded order, from ``start`` seconds on."""
    if topics is not None:
        unknown = [t for t in topics if t not in bag.topics]
        if unknown:
            raise InputError("--topics", unknown, f"topics of the bag: {sorted(bag.topics)}")
    chosen = [m for m in bag.messages if topics is None or m.topic in topics]
    if not chosen:
        raise InputError("bag", str(bag.path), "messages on the chosen topics")
    begin = min(m.log_time_ns for m in chosen) + round(start * 1e9)
    chosen = sorted((m for m in chosen if m.log_time_ns >= begin), key=lambda m: m.log_time_ns)
    if not chosen:
        raise InputError("--start", start, "a time within the bag's messages [s]")
    return chosen


def _qos(profiles: list[dict[str, Any]]) -> Any:
    """What the recorded publishers offered: latched if any was, best effort if all were."""
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    latched = any(p.get("durability") == "transient_local" for p in profiles)
    best_effort = bool(profiles) and all(p.get("reliability") == "best_effort" for p in profiles)
    return QoSProfile(
        depth=100,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
        reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
    )


def _wait_for_subscribers(pubs: dict[str, Any], seconds: float | None) -> None:
    """Discovery before the first message: a fixed 0.5 s, or until every publisher has matched
    a subscriber (at most ``seconds``). Once the writer has matched a reliable reader, the
    reader gets every message from then on."""
    if seconds is None:
        time.sleep(0.5)
        return
    deadline = time.monotonic() + seconds
    while unheard := sorted(p.topic_name for p in pubs.values()
                            if p.get_subscription_count() == 0):  # fmt: skip
        if time.monotonic() >= deadline:
            print(f"fbcc_replay: no subscriber after {seconds:g} s on {unheard}; publishing "
                  "anyway", file=sys.stderr, flush=True)  # fmt: skip
            return
        time.sleep(0.01)


def live_publishers(node: Any, names: list[str], ours: int = 1) -> dict[str, list[str]]:
    """The publishers of the live graph on each of ``names`` that has more than ``ours`` (this
    node's own: a count first, ~5 µs a topic; the names only when there are others)."""
    me = (node.get_name(), node.get_namespace())
    found = {}
    for name in names:
        if node.count_publishers(name) <= ours:
            continue
        found[name] = sorted(f"{i.node_namespace.rstrip('/')}/{i.node_name}"
                             for i in node.get_publishers_info_by_topic(name)
                             if (i.node_name, i.node_namespace) != me)  # fmt: skip
    return found


def _named(found: dict[str, list[str]]) -> bool:
    """Whether DDS has told the names of every publisher found (they lag its discovery)."""
    return not any("_UNKNOWN_" in n for names in found.values() for n in names)


def _live_said(found: dict[str, list[str]]) -> str:
    return "; ".join(f"{t} ({', '.join(names)})" for t, names in found.items())


def republish(
    bag: Bag,
    messages: list[Any],
    rate: float,
    loop: bool,
    ros_args: list[str],
    wait_for_subscribers: float | None = None,
    prefix: str = PREFIX,
) -> int:
    """Publishes ``messages`` at their recorded pace / ``rate``, each topic under ``prefix``
    (module doc); returns how many."""
    import rclpy
    from rclpy.duration import Duration
    from rclpy.node import Node

    from fbcc_ros.bag.schema import message_class

    context = rclpy.Context()
    rclpy.init(args=["fbcc_replay", *ros_args], context=context)
    node = Node("fbcc_replay", context=context)
    root = prefix.rstrip("/")
    try:
        chosen = sorted({m.topic for m in messages})
        names = [node.resolve_topic_name(root + t) for t in chosen]
        # the live graph, discovered before any publisher of ours exists: a publisher of the
        # replay on a cell's input would itself fault the cell (one source per input)
        deadline = time.monotonic() + DISCOVERY
        while time.monotonic() < deadline:
            found = live_publishers(node, names, ours=0)
            if found and _named(found):
                break
            time.sleep(0.02)
        if found:
            raise InputError("--prefix", prefix, "a namespace without live publishers: "
                             f"{_live_said(found)} publish there now (a cell is running)")
        pubs = {t: node.create_publisher(message_class(bag.topics[t]), root + t,
                                         _qos(bag.qos.get(t, [])))
                for t in chosen}  # fmt: skip
        _wait_for_subscribers(pubs, wait_for_subscribers)
        t0 = messages[0].log_time_ns
        span = (messages[-1].log_time_ns - t0) * 1e-9 / rate
        sent = 0
        while True:
            wall0, said = time.monotonic(), 0
            looked = wall0
            for m in messages:
                due = wall0 + (m.log_time_ns - t0) * 1e-9 / rate
                if (wait := due - time.monotonic()) > 0:
                    time.sleep(wait)
                pubs[m.topic].publish(m.data)
                sent += 1
                if (now := time.monotonic()) >= looked + LOOK_PERIOD:
                    looked = now
                    if found := live_publishers(node, names):
                        raise LiveGraphError(f"stopped: {_live_said(found)} began publishing "
                                             "on a replayed topic (a cell started)")  # fmt: skip
                if (elapsed := time.monotonic() - wall0) >= said + 1:
                    said += 1
                    print(f"  {elapsed:5.1f} s of {span:.1f} s, {sent} messages", flush=True)
            if not loop:
                for pub in pubs.values():  # reliable subscribers get the last ones too
                    pub.wait_for_all_acked(Duration(seconds=2.0))
                return sent
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)


class LiveGraphError(Exception):
    """A live publisher appeared on a replayed topic while the replay ran."""


def offline(bag: Bag, params: list[Path], out: Path | None, namespace: str | None = None
            ) -> int:  # fmt: skip
    from fbcc_ros.bag.offline import node_parameters, replay_offline

    given = node_parameters(bag.path, params)
    result = replay_offline(bag, given, namespace)
    error = result.max_error()
    counts = ", ".join(f"{k} {v}" for k, v in result.counts.items())
    print(f"offline: {counts}; phase {result.phase}")
    names = FEATURE_NAMES
    print("largest |offline - recorded| command: "
          + ", ".join(f"{n} {e:.3g}" for n, e in zip(names, error, strict=True)))  # fmt: skip
    compared = int(np.isfinite(result.recorded).all(axis=1).sum())
    reproduced = compared > 0 and bool((error <= TOLERANCE).all())
    if compared == 0:
        print("the bag has no recorded commands to compare with")
    else:
        print(f"{'reproduces' if reproduced else 'DIFFERS FROM'} the {compared} recorded commands "
              f"(tolerance {TOLERANCE:g} m, rad)")  # fmt: skip
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        with (out / "offline.csv").open("w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(["t", *names, *(f"recorded_{n}" for n in names)])
            for t, c, r in zip(result.t, result.commands, result.recorded, strict=True):
                writer.writerow([f"{t:.6f}", *map(repr, c.tolist()), *map(repr, r.tolist())])
        summary = {"bag": str(bag.path), "counts": result.counts, "phase": result.phase,
                   "max_error": dict(zip(names, error.tolist(), strict=True)),
                   "tolerance": TOLERANCE, "compared": compared, "reproduced": reproduced,
                   "parameters": given}  # fmt: skip
        (out / "offline.json").write_text(json.dumps(summary, indent=2) + "\n")
        print(f"wrote {out / 'offline.csv'} and {out / 'offline.json'}")
    # with the bag's own parameters a difference is a regression; with --params, the point
    return 1 if compared and not reproduced and not params else 0


@command("fbcc_replay")
def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    ros_args: list[str] = []
    if "--ros-args" in argv:
        i = argv.index("--ros-args")
        argv, ros_args = argv[:i], argv[i:]
    args = _parser().parse_args(argv)
    try:
        if not args.rate > 0:
            raise InputError("--rate", args.rate, "a speed factor > 0")
        wait = args.wait_for_subscribers
        if wait is not None and not 0 <= wait < float("inf"):
            raise InputError("--wait-for-subscribers", wait, "a time >= 0 [s]")
        bag = read_bag(args.bag)
        if bag.truncated:
            print(f"fbcc_replay: the bag is truncated ({bag.truncated}); replaying what it has",
                  file=sys.stderr)  # fmt: skip
        if args.offline:
            return offline(bag, list(args.params), args.out, args.namespace)
        if not args.prefix.startswith("/"):
            raise InputError("--prefix", args.prefix, "an absolute namespace (/replay), or / "
                             "for the recorded names")  # fmt: skip
        messages = schedule(bag, args.topics, args.start)
        if args.prefix.rstrip("/") == "":
            held = sorted({m.topic for m in messages if never_live(m.topic)})
            messages = [m for m in messages if not never_live(m.topic)]
            if held:
                print(f"fbcc_replay: not published onto the recorded names: {held} (the arm's "
                      "commands and the phase; --prefix /replay publishes them there)",
                      flush=True)  # fmt: skip
            if not messages:
                raise InputError("--topics", args.topics, "a topic other than the commands "
                                 "and the phase with --prefix /")  # fmt: skip
        span = (messages[-1].log_time_ns - messages[0].log_time_ns) * 1e-9
        print(f"fbcc_replay: {len(messages)} messages on {len({m.topic for m in messages})} "
              f"topics under {args.prefix}, {span:.1f} s at rate {args.rate:g}"
              f"{' (loop)' if args.loop else ''}", flush=True)  # fmt: skip
        sent = republish(bag, messages, args.rate, args.loop, ros_args, wait, args.prefix)
    except KeyboardInterrupt:
        return 0
    except LiveGraphError as exc:
        print(f"fbcc_replay: {exc}", file=sys.stderr)
        return 1
    print(f"fbcc_replay: published {sent} messages")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
