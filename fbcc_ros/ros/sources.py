"""One source per input: a node's inputs each have one publisher, and what it commands has no
other commander.

A second publisher on a sensor topic interleaves its samples with the real ones: a stray node
publishing zero wrenches stamped 30 ms ahead had every real reading refused as out of order,
and the law and the wrench guard saw only its zeros (the true force reached 1.5 kN). A second
commander on the arm's command topic moves the arm under the controller. Neither is visible in
the data; both are in the ROS graph. :class:`SourceWatch` counts the publishers of a node's
input topics, and of its command topics besides its own, every :data:`PERIOD` (a count costs
about 5 µs; the names are asked for only when it is wrong), and reports each problem once
when it appears, naming the publishers' nodes. The node decides what a report does (the
controller faults, the compensation trips its wrench guard, the kinematics reports a fault);
:meth:`SourceWatch.forget` (on a reset) reports a problem still there anew.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from rclpy.node import Node

#: How often the graph is looked at [s]: a stray is named within this of its discovery.
PERIOD = 0.02


class SourceWatch:
    """Args:
    node: The node whose inputs and commands these are.
    inputs: Topics (relative names, as the node subscribes them) that must have one publisher.
    commands: Topics the node publishes that nobody else may.
    report: Called with a line for each problem when it first appears.
    """

    def __init__(self, node: Node, inputs: Sequence[str], commands: Sequence[str],
                 report: Callable[[str], None]) -> None:  # fmt: skip
        self.node = node
        self.inputs = [node.resolve_topic_name(t) for t in inputs]
        self.commands = [node.resolve_topic_name(t) for t in commands]
        self.report = report
        #: the problems seen at the last look, each a line
        self.problems: list[str] = []
        self._said: set[str] = set()
        node.create_timer(PERIOD, self.check)

    @property
    def said(self) -> str:
        """The problems seen at the last look, in one line (``""``: none)."""
        return "; ".join(self.problems)

    def _publishers(self, topic: str, mine: bool) -> list[str]:
        """The nodes publishing ``topic``; without ``mine``, this node left out."""
        me = (self.node.get_name(), self.node.get_namespace())
        return sorted(f"{info.node_namespace.rstrip('/')}/{info.node_name}"
                      for info in self.node.get_publishers_info_by_topic(topic)
                      if mine or (info.node_name, info.node_namespace) != me)  # fmt: skip

    def check(self) -> None:
        """One look at the graph (the timer's)."""
        count = self.node.count_publishers
        problems = []
        for topic in self.inputs:
            if count(topic) > 1:
                names = self._publishers(topic, mine=True)
                twice = (": the same node twice (a second instance, or a dead one DDS has not "
                         "forgotten yet)" if len(set(names)) < len(names) else "")
                problems.append(f"{len(names)} publishers on {topic} ({', '.join(names)}){twice}"
                                ": one source per input")  # fmt: skip
        for topic in self.commands:
            if count(topic) > 1:
                others = self._publishers(topic, mine=False)
                if others:
                    problems.append(f"another commander on {topic}: {', '.join(others)}")
        self.problems = problems
        for line in problems:
            if line not in self._said:
                self.report(line)
        self._said = set(problems)

    def forget(self) -> None:
        """Report the problems still there anew (the fault they caused was acknowledged)."""
        self._said = set()
