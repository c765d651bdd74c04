"""Runs a set of nodes for a while — in this process on one executor
(:func:`~fbcc_ros.ros.executor.make_executor`), or each as its own process — beside an
:class:`~fbcc_ros.harness.observer.Observer`, and accounts the CPU each node used. The bringup
and the loop benchmark are built on it.

In one process the cell's nodes are chained (``chain``, the default): the compensated wrench,
the features and the command go from node to node as calls within one callback, and are still
published for the observer, the recorder and anyone else.

CPU per node: in one process, the thread CPU time spent in each node's callbacks, a chained
callback counted under its own node (the rest of the process's CPU is the executor,
(de)serialisation and DDS, reported as ``executor``); as processes, each process's user +
system time from ``/proc``.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from fbcc_ros.core.errors import FbccError
from fbcc_ros.core.param_files import file_parameters
from fbcc_ros.ros.executor import make_executor
from fbcc_ros.ros.params import settle


@dataclass
class NodeSpec:
    """A node to run: its name, its class for the in-process mode, its parameter overrides
    (applied after its parameter ``files``), whether it runs in its own process even when the
    others share this one (the recorder: its disk writes stay off the loop's core), its
    namespace, and the command line that runs it as a process (``python -m`` and its
    arguments; default ``fbcc_ros.nodes <name>``, as its console script runs it)."""

    name: str
    factory: Callable[..., Any]
    parameters: dict[str, Any] = field(default_factory=dict)
    own_process: bool = False
    files: tuple[Path, ...] = ()
    namespace: str = ""
    module: tuple[str, ...] = ()


#: The chain links in one process: (upstream node, its outlet, downstream node, its callback).
CHAIN = (("dynamic_compensation", "out_compensated", "fbcc_controller", "on_wrench"),
         # a trip reaches the controller in the callback that trips it: its hold goes out at
         # once, not after the executor's queue (22 ms of further pressing, measured)
         ("dynamic_compensation", "out_guard", "fbcc_controller", "on_fault"),
         ("kinematics", "out_features", "fbcc_controller", "on_features"),
         ("fbcc_controller", "out_command", "kinematics", "on_command"))  # fmt: skip


def ros_args(parameters: dict[str, Any]) -> list[str]:
    """``--ros-args -p name:=value ...`` (values in YAML, as ``ros2 run`` takes them)."""
    args = ["--ros-args"]
    for name, value in parameters.items():
        text = str(value).lower() if isinstance(value, bool) else str(value)
        args += ["-p", f"{name}:={text}"]
    return args


class CellRun:
    """Context manager: a private rclpy context, an observer, and the nodes of ``specs``."""

    def __init__(
        self,
        specs: list[NodeSpec],
        processes: bool = False,
        probe: bool = False,
        log_dir: Path | None = None,
        chain: bool = True,
        namespace: str = "",
        command_topic: str = "joint_command",
    ) -> None:
        import rclpy

        from fbcc_ros.harness.observer import Observer

        self.specs = specs
        self.processes = processes
        self.namespace = namespace
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.executor = make_executor(self.context)
        self.observer = Observer(probe=probe, context=self.context, namespace=namespace,
                                 command_topic=command_topic)  # fmt: skip
        self.nodes: dict[str, Any] = {}
        self.procs: dict[str, subprocess.Popen[bytes]] = {}
        self._callback_cpu: dict[str, int] = {}
        self._nested: list[int] = []
        #: the links made by :meth:`_chain` ("upstream.outlet -> downstream.callback")
        self.chained: list[str] = []
        self._time_callbacks("observer", self.observer)
        self.executor.add_node(self.observer)
        # the spawned nodes' output, for the message if one dies
        if log_dir is None and any(processes or spec.own_process for spec in specs):
            log_dir = Path(tempfile.mkdtemp(prefix="fbcc_cell_"))
        self.log_dir = log_dir or Path(".")
        try:
            for spec in specs:
                if processes or spec.own_process:
                    self._spawn(spec)
                else:
                    self._construct(spec)
            if chain:
                self._chain()
            settle(self.nodes.values())
        except BaseException:
            self.close()
            raise

    def _construct(self, spec: NodeSpec) -> None:
        self._add(spec.name, self._build(spec))

    def _build(self, spec: NodeSpec) -> Any:
        from rclpy.parameter import Parameter

        values = {**file_parameters(spec.files, spec.name), **spec.parameters}
        overrides = [Parameter(k, value=v) for k, v in values.items()]
        return spec.factory(context=self.context, parameter_overrides=overrides,
                            namespace=spec.namespace)  # fmt: skip

    def _add(self, name: str, node: Any) -> None:
        self._time_callbacks(name, node)
        self.nodes[name] = node
        self.executor.add_node(node)

    def _time_callbacks(self, name: str, node: Any) -> None:
        """Wraps every callback of ``node`` to sum its thread CPU time under ``name``."""
        self._callback_cpu.setdefault(name, 0)  # a restarted node sums on
        for entity in (*node.subscriptions, *node.timers, *node.services):
            entity.callback = self._timed(name, entity.callback)

    def _timed(self, name: str, inner: Callable[..., Any]) -> Callable[..., Any]:
        """``inner``, its thread CPU time summed under ``name``, less what the callbacks it
        calls in turn (a chain, :meth:`_chain`) sum under their own names."""
        def timed(*args: Any) -> Any:
            t0 = time.thread_time_ns()
            self._nested.append(0)
            try:
                return inner(*args)
            finally:
                elapsed = time.thread_time_ns() - t0
                self._callback_cpu[name] += elapsed - self._nested.pop()
                if self._nested:
                    self._nested[-1] += elapsed

        return timed

    def _chain(self, only: str | None = None) -> None:
        """The cell's nodes in this process, chained: each output goes to the node that takes
        it as a call in the same callback, not through DDS and the executor (that node's
        subscription to it is removed); it is still published for everyone else. ``only``:
        the links of that node alone (restarted, :meth:`restart`)."""
        for up_name, outlet, down_name, callback in CHAIN:
            up, down = self.nodes.get(up_name), self.nodes.get(down_name)
            if up is None or down is None or not (hasattr(up, outlet) and hasattr(down, callback)):
                continue  # a node of another kind (the benchmark's bare chain)
            if only is not None and only not in (up_name, down_name):
                continue
            topic = down.resolve_topic_name(getattr(up, outlet).publisher.topic_name)
            for sub in [s for s in down.subscriptions if s.topic_name == topic]:
                down.destroy_subscription(sub)
            _unlink(getattr(up, outlet), down_name)
            link = self._timed(down_name, getattr(down, callback))
            link.chained_to = down_name  # type: ignore[attr-defined]
            getattr(up, outlet).link(link)  # a latched outlet passes its last message
            if only is None:
                self.chained.append(f"{up_name}.{outlet} -> {down_name}.{callback}")

    def restart(self, name: str, parameters: dict[str, Any] | None = None,
                timeout: float = 60.0) -> None:  # fmt: skip
        """Kills the node ``name`` and starts it anew (with ``parameters`` changed, if given)
        while the others run on; returns once it is up (its parameter services answer).

        A process is killed by SIGKILL, as a crash ends it (its endpoints stay in the graph
        until its lease ends), and started again. A node of this process is destroyed, built
        in a thread as this one spins, and chained in its old place: beside running nodes, but
        with its modules imported and without DDS discovery (faster than a process)."""
        spec = next((s for s in self.specs if s.name == name), None)
        if spec is None or name not in {*self.nodes, *self.procs}:
            raise FbccError(f"cannot restart {name}: not a node of this cell "
                            f"({sorted({*self.nodes, *self.procs})})")  # fmt: skip
        if parameters:
            index = self.specs.index(spec)
            spec = self.specs[index] = replace(spec, parameters={**spec.parameters,
                                                                 **parameters})  # fmt: skip
        if name in self.procs:
            self._respawn(spec, timeout)
        else:
            self._rebuild(spec)

    def _respawn(self, spec: NodeSpec, timeout: float) -> None:
        from rcl_interfaces.srv import GetParameters

        old = self.procs.pop(spec.name)
        old.kill()
        old.wait()
        with (self.log_dir / f"{spec.name}.log").open("ab") as log:
            log.write(b"\n--- killed (SIGKILL) and started anew ---\n")
        self._spawn(spec, append=True)
        # up when its own services answer (the dead one's endpoints may still be in the graph)
        client = self.observer.create_client(
            GetParameters, f"{spec.namespace.rstrip('/')}/{spec.name}/get_parameters")
        deadline = time.monotonic() + timeout
        try:
            while True:  # a request sent before the new one was matched is answered by none
                future = client.call_async(GetParameters.Request(names=["use_sim_time"]))
                end = time.monotonic() + 1.0
                while not future.done() and time.monotonic() < end:
                    self.executor.spin_once(timeout_sec=0.01)
                if future.done():
                    return
                self.check_alive()
                if time.monotonic() > deadline:
                    raise FbccError(f"{spec.name} did not come up within {timeout:g} s")
        finally:
            self.observer.destroy_client(client)

    def _rebuild(self, spec: NodeSpec) -> None:
        import gc
        import threading

        name = spec.name
        old = self.nodes.pop(name)
        self._unchain_into(name)  # nothing calls into the dead node
        self.executor.remove_node(old)
        for entity in (*old.subscriptions, *old.timers, *old.services):
            entity.callback = _dead  # an event the executor queued before the removal
        old.destroy_node()
        built: list[Any] = []

        def build() -> None:
            try:
                node = self._build(spec)
                if hasattr(node, "preload"):
                    node.preload()
                built.append(node)
            except BaseException as exc:  # raised below, in this thread
                built.append(exc)

        thread = threading.Thread(target=build, name=f"restart {name}")
        thread.start()
        while thread.is_alive():
            self.executor.spin_once(timeout_sec=0.01)
        if isinstance(built[0], BaseException):
            raise built[0]
        self._add(name, built[0])
        self._chain(only=name)
        gc.freeze()  # as settle does, without its full collection in the running loop

    def freeze(self, name: str) -> None:
        """The node ``name`` of this process stops running, as a stopped process does: its
        callbacks leave the executor and the chained calls into it are withheld (what is
        sent to it meanwhile waits in its subscriptions' queues, or is lost). :meth:`thaw`
        lets it go on."""
        self._unchain_into(name)
        self.executor.remove_node(self.nodes[name])

    def _unchain_into(self, name: str) -> None:
        for up_name, outlet, down_name, _ in CHAIN:
            if down_name == name and hasattr(self.nodes.get(up_name), outlet):
                _unlink(getattr(self.nodes[up_name], outlet), name)

    def thaw(self, name: str) -> None:
        """The node frozen by :meth:`freeze` runs again, chained in its old place."""
        self.executor.add_node(self.nodes[name])
        self._chain(only=name)

    def _spawn(self, spec: NodeSpec, append: bool = False) -> None:
        self.log_dir.mkdir(parents=True, exist_ok=True)
        files = [arg for f in spec.files for arg in ("--params-file", str(f))]
        module = spec.module or ("fbcc_ros.nodes", spec.name)
        cmd = [sys.executable, "-m", *module, "--ros-args", *files,
               *ros_args(spec.parameters)[1:]]  # the files, then the values over them
        if spec.namespace:
            cmd += ["-r", f"__ns:={spec.namespace}"]
        with (self.log_dir / f"{spec.name}.log").open("ab" if append else "wb") as log:
            self.procs[spec.name] = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT)

    def check_alive(self) -> None:
        for name, proc in self.procs.items():
            if proc.poll() is not None:
                tail = (self.log_dir / f"{name}.log").read_text(errors="replace")[-600:]
                raise FbccError(f"node {name} exited with status {proc.returncode}:\n{tail}")

    def spin_until(self, done: Callable[[], bool], timeout: float, what: str) -> None:
        deadline = time.monotonic() + timeout
        while not done():
            self.executor.spin_once(timeout_sec=0.01)
            self.check_alive()
            if time.monotonic() > deadline:
                raise FbccError(f"{what} within {timeout:.0f} s")

    def spin_for(self, seconds: float, every_second: Callable[[float], None],
                 longer: Callable[[float], bool] = lambda _: False) -> None:
        start = time.monotonic()
        said = 0
        while (elapsed := time.monotonic() - start) < seconds or longer(elapsed):
            self.executor.spin_once(timeout_sec=0.01)
            if elapsed >= said + 1:
                said += 1
                self.check_alive()
                every_second(elapsed)

    def call(self, client: Any, timeout: float = 10.0, request: Any = None) -> Any:
        """A service call over DDS (``request``; a std_srvs/Trigger one by default); returns
        the response."""
        from std_srvs.srv import Trigger

        name = client.srv_name
        self.spin_until(client.service_is_ready, timeout, f"no service {name}")
        future = client.call_async(Trigger.Request() if request is None else request)
        self.spin_until(future.done, timeout, f"no answer from {name}")
        return future.result()

    def heard(self, kind: Any, topic: str, qos: Any = 10, timeout: float = 5.0) -> Any:
        """The next message on ``topic`` (relative: in the cell's namespace), the cell running
        meanwhile; with a latched ``qos``, the last one sent."""
        got: list[Any] = []
        sub = self.observer.create_subscription(kind, topic, got.append, qos)
        try:
            self.spin_until(lambda: bool(got), timeout, f"no message on {topic}")
        finally:
            self.observer.destroy_subscription(sub)
        return got[0]

    def fresh_status(self, nodes: tuple[str, ...], timeout: float = 3.0) -> None:
        """Spins until each of ``nodes`` has sent its ``/diagnostics`` after this call (they
        send once a second): what they report then covers all that came before."""
        since = time.monotonic()
        status = self.observer.status
        self.spin_until(lambda: all(status.get(n, (0.0,))[0] > since for n in nodes), timeout,
                        f"no /diagnostics from all of {', '.join(nodes)}")  # fmt: skip

    def cpu(self) -> dict[str, float]:
        """CPU seconds so far (diff two calls for a window): per node, the observer's callbacks,
        and ``executor``, the rest of this process (all of it, with processes)."""
        out = {name: ns * 1e-9 for name, ns in self._callback_cpu.items()}
        out["executor"] = time.process_time() - sum(out.values())
        out.update({name: _process_cpu(proc.pid) for name, proc in self.procs.items()})
        return out

    def close(self) -> None:
        """Stops the nodes, here and in their processes, then the processes of their own (the
        recorder), which so records what a node publishes as it stops."""
        import rclpy

        for node in self.nodes.values():
            node.destroy_node()
        last = {spec.name for spec in self.specs if spec.own_process}
        for wave in (set(self.procs) - last, last & set(self.procs)):
            procs = [self.procs[name] for name in wave]
            for proc in (p for p in procs if p.poll() is None):
                proc.send_signal(signal.SIGINT)
            for proc in procs:
                try:
                    proc.wait(timeout=30)  # the controller first drains its filter's answers
                except subprocess.TimeoutExpired:  # rclpy catches SIGTERM: only SIGKILL is sure
                    proc.kill()
                    proc.wait()
        self.observer.destroy_node()
        self.executor.shutdown()
        rclpy.try_shutdown(context=self.context)
        # release the context's DDS participant now: left to the collector, each run's stayed
        # alive, its threads receiving every later run's traffic (in a bench of 16 runs the
        # harness's process then took 0.95 of a core)
        self.context.destroy()

    def __enter__(self) -> CellRun:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _unlink(outlet: Any, down_name: str) -> None:
    """The outlet's chain link to ``down_name`` removed."""
    outlet.local[:] = [c for c in outlet.local if getattr(c, "chained_to", None) != down_name]


def _dead(*_: Any) -> None:
    """The callback of a killed node's entity."""


def _process_cpu(pid: int) -> float:
    """User + system CPU seconds of a live process (Linux ``/proc/<pid>/stat``)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return float("nan")
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
