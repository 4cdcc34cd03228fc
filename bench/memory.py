"""Memory benchmark: the resident set (RSS) a bus node needs for N axes.

For each N, a fresh Python process boots N simulated generic CiA 402 drives (the demo's drive, one
axis per node, SYNC 4 ms), measures the RSS with the simulators alone, then starts a BusNode on
their bus (rclpy, every topic and service), enables the axes, lets it publish joint states every
cycle for ``--seconds`` and measures again: the bridge's share is the difference. The baseline,
in the same process before the bridge, is a naive rclpy node publishing a JointState of N joints
from a 4 ms timer: every figure is also given as a ratio to it.

    .venv/bin/python -m bench memory [--axes 1 2 4 8] [--seconds 5]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

MB = 2 ** 20


def bus_yaml(axes: int, channel: str) -> str:
    import yaml
    nodes = {f'drive_{i}': {'node_id': 2 + i, 'axes': [{'joint': f'joint_{i}', 'scaling': {
        'counts_per_revolution': 65536, 'rated_torque': 1.0}}]} for i in range(axes)}
    return yaml.safe_dump({'bus': {'interface': 'virtual', 'channel': channel},
                           'master': {'node_id': 127, 'sync_period': 4000, 'heartbeat_producer': 100},
                           'defaults': {'family': 'generic_402', 'heartbeat_producer': 100},
                           'nodes': nodes, 'simulation': {'enabled': True}}, sort_keys=False)


def measure(axes: int, seconds: float, kind: str) -> dict[str, float]:
    """Runs in a child process: RSS after the imports, with the simulators, and with ``kind``
    ('naive' or 'bridge') running for ``seconds``, in bytes."""
    import gc
    import threading

    import psutil
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import JointState

    from drive_bridge.config import load_bus_config_text
    from drive_bridge.ros.node import BusNode
    from drive_bridge.sim import SimulatedBus

    process = psutil.Process()

    def rss() -> float:
        gc.collect()
        return float(process.memory_info().rss)

    text = bus_yaml(axes, f'bench-memory-{os.getpid()}')
    figures = {'imports': rss()}
    sim = SimulatedBus(load_bus_config_text(text)).start()
    time.sleep(1.0)
    figures['sim'] = rss()
    rclpy.init()
    executor = SingleThreadedExecutor()
    node: Node
    if kind == 'naive':
        node = Node('naive_bridge')
        publisher = node.create_publisher(JointState, '/joint_states', 10)
        names = [f'joint_{i}' for i in range(axes)]
        zeros = [0.0] * axes
        node.create_timer(0.004, lambda: publisher.publish(JointState(name=names, position=zeros, velocity=zeros,
                                                                      effort=zeros)))
    else:  # the simulators run already: the node gets their bus without starting its own
        node = BusNode(parameter_overrides=[
            Parameter('config_yaml', value=text.replace('enabled: true', 'enabled: false')),
            Parameter('auto_enable', value=True)])
    executor.add_node(node)
    threading.Thread(target=executor.spin, daemon=True).start()
    if isinstance(node, BusNode):
        node.master.wait_until_operational(20.0)
    time.sleep(seconds)
    figures['running'] = rss()
    figures['threads'] = float(threading.active_count())
    if isinstance(node, BusNode):
        node.close()
    executor.shutdown()
    sim.stop()
    return figures


def run(axes: int, seconds: float, kind: str) -> dict[str, float]:
    # a ROS domain of this run's own: no other node's traffic in the figures
    env = {**os.environ, 'ROS_DOMAIN_ID': os.environ.get('ROS_DOMAIN_ID', str(1 + os.getpid() % 100))}
    out = subprocess.run([sys.executable, '-m', 'bench.memory', '--child', kind, '--axes', str(axes),
                          '--seconds', str(seconds)], check=True, capture_output=True, text=True, env=env)
    return json.loads(out.stdout.strip().splitlines()[-1])  # type: ignore[no-any-return]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog='bench memory', description=__doc__.split('\n\n')[0])
    parser.add_argument('--axes', nargs='+', type=int, default=[1, 2, 4, 8], help='axes on the bus (1..8)')
    parser.add_argument('--seconds', type=float, default=5.0, help='running time before each measurement')
    parser.add_argument('--child', choices=('naive', 'bridge'), help=argparse.SUPPRESS)
    options = parser.parse_args(argv)
    if options.child:
        print(json.dumps(measure(options.axes[0], options.seconds, options.child)))
        return
    print('| axes | Python + imports (MB) | naive rclpy node (MB) | bus node (MB) | bus node / naive | '
          'bridge process without simulators (MB) | threads |')
    print('|---|---|---|---|---|---|---|')
    for axes in options.axes:
        naive, bridge = run(axes, options.seconds, 'naive'), run(axes, options.seconds, 'bridge')
        naive_mb = (naive['running'] - naive['sim']) / MB
        bridge_mb = (bridge['running'] - bridge['sim']) / MB
        alone = (bridge['running'] - (bridge['sim'] - bridge['imports'])) / MB
        print(f'| {axes} | {bridge["imports"] / MB:.1f} | {naive_mb:.1f} | {bridge_mb:.1f} | '
              f'{bridge_mb / naive_mb:.1f} | {alone:.1f} | {bridge["threads"]:.0f} |', flush=True)


if __name__ == '__main__':
    main()
