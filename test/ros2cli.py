"""A stand-in for the few ``ros2`` command-line verbs the docs show, for this PyPI environment,
which has rclpy but no ros2cli: ``service call``, ``topic pub``, ``topic echo``, ``action
send_goal``, ``param get/set/describe``, ``lifecycle set/get``.

The request text is read as ros2cli reads it (``yaml.safe_load``, then the fields set one by one
as ``rosidl_runtime_py.set_message_fields`` does: nested mappings into messages, lists of
mappings into lists of messages, scalars converted to the field's Python type), so a docs
example that works here has the field names, nesting and types ``ros2`` needs. Only that part of
ros2cli is mirrored; output is a plain repr, not ros2cli's YAML.

    .venv/bin/python test/ros2cli.py service call /drive_bridge/enable \
        drive_bridge_interfaces/srv/AxisCommand "{joints: []}"
"""
from __future__ import annotations

import argparse
import importlib
import shlex
import sys
import time
from typing import Any

import yaml

TIMEOUT = 30.0


class CliError(Exception):
    """The command cannot run as given: the text says what was wrong."""


def interface_type(name: str) -> Any:
    """``pkg/srv/Name`` (or ``pkg/Name`` of a message) as its Python class."""
    parts = name.split('/')
    if len(parts) == 2:
        parts = [parts[0], 'msg', parts[1]]
    if len(parts) != 3:
        raise CliError(f'{name!r} is not a type name pkg/msg|srv|action/Name')
    try:
        return getattr(importlib.import_module(f'{parts[0]}.{parts[1]}'), parts[2])
    except (ImportError, AttributeError) as exc:
        raise CliError(f'unknown type {name}: {exc}') from None


def set_fields(msg: Any, values: Any, where: str = '') -> None:
    """``values`` (a mapping from YAML) into ``msg``, field by field, strictly."""
    if values is None:
        return
    if not isinstance(values, dict):
        raise CliError(f'{where or "request"}: expected a mapping of fields, got {values!r}')
    fields = msg.get_fields_and_field_types()
    for name, value in values.items():
        path = f'{where}.{name}' if where else name
        if name not in fields:
            raise CliError(f'{path}: {type(msg).__name__} has no field {name!r} (fields: {", ".join(fields)})')
        current = getattr(msg, name)
        if hasattr(current, 'get_fields_and_field_types'):
            set_fields(current, value, path)
            continue
        field_type = fields[name]
        if field_type.startswith('sequence<') or field_type.endswith(']'):
            element = field_type.removeprefix('sequence<').split('>')[0].split('[')[0].split(',')[0]
            if '/' in element:
                items = []
                for i, item in enumerate(value or []):
                    child = interface_type(element.replace('/', '/msg/', 1))()
                    set_fields(child, item, f'{path}[{i}]')
                    items.append(child)
                setattr(msg, name, items)
            else:
                setattr(msg, name, [_scalar(element, v, f'{path}[{i}]') for i, v in enumerate(value or [])])
            continue
        setattr(msg, name, _scalar(field_type, value, path))


def _scalar(field_type: str, value: Any, path: str) -> Any:
    try:
        if field_type in ('float', 'double'):
            return float(value)
        if field_type == 'boolean':
            if not isinstance(value, bool):
                raise TypeError(f'expected true or false, got {value!r}')
            return value
        if field_type.startswith('string'):
            if not isinstance(value, str):
                raise TypeError(f'expected a string, got {value!r}')
            return value
        if 'int' in field_type or field_type in ('octet', 'char'):
            if isinstance(value, bool) or not isinstance(value, int):
                raise TypeError(f'expected an integer, got {value!r}')
            return value
    except (TypeError, ValueError) as exc:
        raise CliError(f'{path}: {exc}') from None
    return value


def parse_values(text: str) -> Any:
    try:
        return yaml.safe_load(text) if text else None
    except yaml.YAMLError as exc:
        raise CliError(f'the request is not YAML: {exc}') from None


class Session:
    """One rclpy node making the calls; closed with :meth:`close`."""

    def __init__(self, context: Any = None) -> None:
        import rclpy
        from rclpy.node import Node
        self.rclpy = rclpy
        self.own_context = context is None
        if self.own_context:
            context = rclpy.Context()
            rclpy.init(context=context)
        self.context = context
        self.node = Node(f'ros2cli_{int(time.monotonic() * 1000) % 100000}', context=context)
        from rclpy.executors import SingleThreadedExecutor
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        if self.own_context:
            self.rclpy.try_shutdown(context=self.context)

    def wait(self, future: Any, what: str, timeout: float = TIMEOUT) -> Any:
        self.executor.spin_until_future_complete(future, timeout_sec=timeout)
        if not future.done():
            raise CliError(f'{what}: no answer within {timeout:.0f} s')
        return future.result()

    def service(self, name: str, type_name: str, values: Any) -> Any:
        srv = interface_type(type_name)
        request = srv.Request()
        set_fields(request, values)
        client = self.node.create_client(srv, name)
        try:
            if not client.wait_for_service(timeout_sec=TIMEOUT):
                raise CliError(f'service {name} is not available')
            return self.wait(client.call_async(request), f'service {name}')
        finally:
            self.node.destroy_client(client)

    def publish(self, topic: str, type_name: str, values: Any, rate: float, times: int) -> Any:
        cls = interface_type(type_name)
        msg = cls()
        set_fields(msg, values)
        publisher = self.node.create_publisher(cls, topic, 10)
        deadline = time.monotonic() + TIMEOUT
        while publisher.get_subscription_count() == 0:
            if time.monotonic() > deadline:
                raise CliError(f'no subscriber of {topic}')
            time.sleep(0.05)
        for _ in range(times):
            publisher.publish(msg)
            time.sleep(1.0 / rate)
        time.sleep(0.2)
        self.node.destroy_publisher(publisher)
        return msg

    def echo(self, topic: str, count: int = 1, timeout: float = TIMEOUT) -> list[Any]:
        deadline = time.monotonic() + timeout
        while True:
            types = dict(self.node.get_topic_names_and_types())
            if topic in types:
                break
            if time.monotonic() > deadline:
                raise CliError(f'topic {topic} does not appear to be published yet')
            time.sleep(0.1)
        cls = interface_type(types[topic][0])
        received: list[Any] = []
        subscription = self.node.create_subscription(cls, topic, received.append, 10)
        try:
            while len(received) < count and time.monotonic() < deadline:
                self.executor.spin_once(timeout_sec=0.1)
        finally:
            self.node.destroy_subscription(subscription)
        if len(received) < count:
            raise CliError(f'{topic}: {len(received)} of {count} message(s) within {timeout:.0f} s')
        return received

    def send_goal(self, name: str, type_name: str, values: Any) -> Any:
        from rostools import ActionClient
        action = interface_type(type_name)
        goal = action.Goal()
        set_fields(goal, values)
        client = ActionClient(self.node, action, name)
        try:
            if not client.wait_for_server(timeout_sec=TIMEOUT):
                raise CliError(f'action server {name} is not available')
            handle = self.wait(client.send_goal_async(goal), f'goal to {name}')
            if not handle.accepted:
                raise CliError(f'goal to {name} rejected')
            return self.wait(handle.get_result_async(), f'result of {name}').result
        finally:
            client.destroy()


def param_value(text: str) -> Any:
    """A parameter value as ``ros2 param set`` reads it (YAML)."""
    from rclpy.parameter import Parameter
    value = yaml.safe_load(text)
    return Parameter('value', value=value).get_parameter_value()


def run(argv: list[str], session: Session) -> Any:
    """One ``ros2 ...`` command line (without ``ros2``); returns what it answered."""
    verb, *rest = argv
    parser = argparse.ArgumentParser(prog=f'ros2 {verb}', exit_on_error=False)
    sub = parser.add_subparsers(dest='sub', required=True)
    if verb == 'service':
        call = sub.add_parser('call')
        call.add_argument('name'), call.add_argument('type'), call.add_argument('values', nargs='?', default='')
        args = parser.parse_args(rest)
        return session.service(args.name, args.type, parse_values(args.values))
    if verb == 'topic':
        pub = sub.add_parser('pub')
        pub.add_argument('--once', action='store_true')
        pub.add_argument('-r', '--rate', type=float, default=1.0)
        pub.add_argument('-t', '--times', type=int, default=0)
        pub.add_argument('topic'), pub.add_argument('type'), pub.add_argument('values', nargs='?', default='')
        echo = sub.add_parser('echo')
        echo.add_argument('--once', action='store_true')
        echo.add_argument('topic'), echo.add_argument('type', nargs='?')
        args = parser.parse_args(rest)
        if args.sub == 'pub':
            times = 1 if args.once else (args.times or 1)
            return session.publish(args.topic, args.type, parse_values(args.values), args.rate, times)
        # without --once: the first message is enough to show the topic works
        return session.echo(args.topic, 1, TIMEOUT if args.once else 3.0) if args.once else \
            _optional_echo(session, args.topic)
    if verb == 'action':
        goal = sub.add_parser('send_goal')
        goal.add_argument('-f', '--feedback', action='store_true')
        goal.add_argument('name'), goal.add_argument('type'), goal.add_argument('values')
        args = parser.parse_args(rest)
        return session.send_goal(args.name, args.type, parse_values(args.values))
    if verb == 'param':
        for name in ('get', 'describe'):
            p = sub.add_parser(name)
            p.add_argument('node'), p.add_argument('name')
        p = sub.add_parser('set')
        p.add_argument('node'), p.add_argument('name'), p.add_argument('value')
        args = parser.parse_args(rest)
        return _param(session, args)
    if verb == 'lifecycle':
        p = sub.add_parser('set')
        p.add_argument('node'), p.add_argument('transition')
        p = sub.add_parser('get')
        p.add_argument('node')
        args = parser.parse_args(rest)
        if args.sub == 'get':
            return session.service(f'{args.node}/get_state', 'lifecycle_msgs/srv/GetState', {})
        ids = {'configure': 1, 'cleanup': 2, 'activate': 3, 'deactivate': 4, 'shutdown': 5}
        if args.transition not in ids:
            raise CliError(f'unknown transition {args.transition!r}')
        return session.service(f'{args.node}/change_state', 'lifecycle_msgs/srv/ChangeState',
                               {'transition': {'id': ids[args.transition]}})
    raise CliError(f'ros2 {verb}: not a verb this stand-in knows')


def _optional_echo(session: Session, topic: str) -> list[Any]:
    """``ros2 topic echo`` without --once waits for messages that may never come (EMCY,
    command errors): here the topic must exist; messages within 3 s are returned."""
    try:
        return session.echo(topic, 1, 3.0)
    except CliError as exc:
        if 'does not appear' in str(exc):
            raise
        return []


def _param(session: Session, args: argparse.Namespace) -> Any:
    from rcl_interfaces.msg import Parameter as ParameterMsg
    if args.sub == 'get':
        return session.service(f'{args.node}/get_parameters', 'rcl_interfaces/srv/GetParameters',
                               {'names': [args.name]}).values[0]
    if args.sub == 'describe':
        return session.service(f'{args.node}/describe_parameters', 'rcl_interfaces/srv/DescribeParameters',
                               {'names': [args.name]}).descriptors[0]
    from rcl_interfaces.srv import SetParameters
    client = session.node.create_client(SetParameters, f'{args.node}/set_parameters')
    try:
        if not client.wait_for_service(timeout_sec=TIMEOUT):
            raise CliError(f'{args.node} has no parameter services')
        request = SetParameters.Request(parameters=[ParameterMsg(name=args.name, value=param_value(args.value))])
        return session.wait(client.call_async(request), f'set {args.name}').results[0]
    finally:
        session.node.destroy_client(client)


def split_command(line: str) -> list[str]:
    """A docs line ``ros2 ...  # comment`` as its arguments, without ``ros2`` and the comment."""
    words = shlex.split(line, comments=True)
    if not words or words[0] != 'ros2':
        raise CliError(f'not a ros2 command: {line}')
    return words[1:]


def main() -> int:
    session = Session()
    try:
        print(run(sys.argv[1:], session))
    except (CliError, argparse.ArgumentError) as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 1
    finally:
        session.close()
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
