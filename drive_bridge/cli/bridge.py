"""Console entry points: ``bridge`` runs one bus node."""
from __future__ import annotations

import argparse
import os
import sys

from drive_bridge.resources import shipped_config
from drive_bridge.stopsignals import exit_code, stop_on_signals

DEMO_ROS_ARGS = ['--ros-args', '-p', 'auto_enable:=true']


def bridge_main(argv: list[str] | None = None, managed: bool = False) -> None:
    """``bridge [CONFIG] [--ros-args ...]``: run the bus node; no CONFIG runs the demo
    (simulated drives on a virtual bus, enabled once booted). SIGINT or SIGTERM stops it
    whatever the process inherited: the node stops motion, releases the bus, exits 0."""
    args = sys.argv[1:] if argv is None else argv
    ros_args = args[args.index('--ros-args'):] if '--ros-args' in args else []
    own = args[:len(args) - len(ros_args)]
    parser = argparse.ArgumentParser(prog='bridge', description=bridge_main.__doc__)
    parser.add_argument('config', nargs='?', default='',
                        help='bus configuration YAML (default: the shipped demo on a virtual bus)')
    options = parser.parse_args(own)
    config = options.config
    if not config and not any(a.startswith(('config:=', 'config_yaml:=')) for a in ros_args) \
            and not params_files_set_config(ros_args):
        config = str(shipped_config('demo.yaml'))
        ros_args = [*DEMO_ROS_ARGS, *ros_args]
        # The demo must keep DDS on loopback unless the user chose otherwise.
        os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    # Our handlers first: rclpy.init() installs its own (they wake the executor) and chains to
    # them, so the signal ends the spin even where SIGINT came in ignored.
    try:
        with stop_on_signals(interrupt=True):
            from drive_bridge.ros.main import run  # imports rclpy: only after the environment is set
            code = run(config, ['bridge', *ros_args], managed=managed)
    except KeyboardInterrupt as exc:  # before the spin (importing, booting the bus)
        code = exit_code(exc)
    raise SystemExit(code)


def params_files_set_config(ros_args: list[str]) -> bool:
    """Whether a ``--params-file`` of ``ros_args`` sets config or config_yaml (as launch files do):
    then the node is not the demo, and no demo parameter may override the file's."""
    import yaml
    files = [ros_args[i + 1] for i, a in enumerate(ros_args[:-1]) if a == '--params-file']

    def sets_config(data: object) -> bool:
        if not isinstance(data, dict):
            return False
        params = data.get('ros__parameters')
        if isinstance(params, dict) and (params.get('config') or params.get('config_yaml')):
            return True
        return any(sets_config(v) for k, v in data.items() if k != 'ros__parameters')
    for name in files:
        try:
            with open(name, encoding='utf-8') as stream:
                if sets_config(yaml.safe_load(stream)):
                    return True
        except (OSError, UnicodeDecodeError, yaml.YAMLError):
            continue  # rcl reports an unreadable file itself
    return False


def bridge_managed_main(argv: list[str] | None = None) -> None:
    """``bridge_managed``: the lifecycle node; configure boots the bus, activate starts it."""
    bridge_main(argv, managed=True)
