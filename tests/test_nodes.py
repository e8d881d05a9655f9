"""The four nodes as processes (`emla run`): frames on every topic, the deterministic lockstep, the latched
estimate, clean exits; their parameters' descriptors and YAML defaults; `emla run` errors."""
import signal
import subprocess
import time

import numpy as np
import pytest
import rclpy
import yaml
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.parameter import Parameter
from ros_isolation import REPO, VENV_BIN, isolated_env, processes
from rosgraph_msgs.msg import Clock

from emla_control.nodes.controller_node import ControllerNode
from emla_core import topics
from emla_core.nodes.qos import CLOCK_QOS, FRAME_QOS, LATCHED_QOS
from emla_core.nodes.run import ros_node as suite_ros_node
from emla_identification.nodes.identifier_node import IdentifierNode
from emla_msgs.msg import ParameterEstimate, SampleFrame
from emla_sim.nodes.plant_node import PlantNode
from emla_sim.nodes.sensor_node import SensorNode

pytestmark = pytest.mark.timeout(180)

EMLA = str(VENV_BIN / 'emla')
CONFIG = {'plant': REPO / 'emla_sim/config/plant.yaml', 'sensor': REPO / 'emla_sim/config/sensor.yaml',
          'identifier': REPO / 'emla_identification/config/identifier.yaml',
          'controller': REPO / 'emla_control/config/controller.yaml'}
NODE_CLASSES = {'plant': PlantNode, 'sensor': SensorNode, 'identifier': IdentifierNode, 'controller': ControllerNode}
PERIODS, SAMPLES, MS = 300, 10, 1_000_000  # 0.3 s of 1 ms frames of 10 samples; ns per ms
VOLTAGE_TOPICS = [topics.PLANT_TOPICS['voltage'], topics.MEASURED_TOPICS['voltage'], topics.COMMAND_TOPIC,
                  topics.REFERENCE_TOPIC]
STATE_TOPICS = [topics.PLANT_TOPICS[n] for n in ('current', 'position')] + \
               [topics.MEASURED_TOPICS[n] for n in ('current', 'position')]
TRUTH = {'resistance': 4.0, 'inductance': 1.6e-3}
RCLPY_PARAMETERS = {'use_sim_time', 'start_type_description_service'}  # every rclpy node declares them


def ros_node():
    """An rclpy node and executor of this test process in the isolated domain of its node processes."""
    return suite_ros_node('test_nodes', domain=int(isolated_env()['ROS_DOMAIN_ID']))


def spin_until(executor, condition, timeout, procs=()):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, 'timed out'
        for proc in procs:
            assert proc.poll() in (None, 0), f'{proc.args[2]} exited {proc.returncode}: {proc.stderr.read()}'
        executor.spin_once(timeout_sec=0.05)


class Listener:
    """Everything the graph publishes that the test checks, as received."""

    def __init__(self, node):
        self.frames = {topic: [] for topic in VOLTAGE_TOPICS + STATE_TOPICS}
        self.estimates, self.diagnostics, self.done = [], [], []
        self.subscriptions = [node.create_subscription(SampleFrame, topic, lambda msg, frames=frames: frames.append(
            (topics.stamp_to_ns(msg.header.stamp), msg.sample_period, np.array(msg.data))), FRAME_QOS)
            for topic, frames in self.frames.items()]
        self.subscriptions += [
            node.create_subscription(ParameterEstimate, topics.PARAMETERS_TOPIC, self.estimates.append, 10),
            node.create_subscription(DiagnosticArray, topics.DIAGNOSTICS_TOPIC, self.diagnostics.append, 10)]
        node.create_subscription(Time, topics.DONE_TOPIC, self.done.append, LATCHED_QOS)

    def matched(self, topics):
        """Whether the subscriptions to `topics` have matched a publisher."""
        return all(s.get_publisher_count() for s in self.subscriptions if s.topic_name in topics)

    def finished(self):
        return self.done and self.estimates and \
            topics.stamp_to_ns(self.estimates[-1].header.stamp) == topics.stamp_to_ns(self.done[0])

    def signal(self, topic):
        return np.concatenate([data for _, _, data in self.frames[topic]])


def params_file(tmp_path, node, **changes):
    """The package's params file of `node` with some values changed."""
    params = yaml.safe_load(CONFIG[node].read_text())
    params[f'/emla/{node}']['ros__parameters'].update(changes)
    path = tmp_path / f'{node}.yaml'
    path.write_text(yaml.safe_dump(params))
    return str(path)


def wait_exit(proc, timeout=20):
    code = proc.wait(timeout=timeout)
    err = proc.stderr.read()
    assert code == 0 and 'Traceback' not in err, f'{proc.args[2]} exited {code}: {err}'


def run_graph(tmp_path):
    """A 0.3 s run of the four nodes; what the test received. The plant starts once the test's subscriptions
    matched the other nodes' publishers (the volatile ones would miss the first messages otherwise), and
    then waits for three /emla/position readers: controller, identifier, test."""
    others = ('sensor', 'identifier', 'controller')
    with ros_node() as (node, executor), processes() as start:
        listener = Listener(node)
        procs = {name: start([EMLA, 'run', name, '--params-file', str(CONFIG[name])]) for name in others}
        outputs = [*topics.MEASURED_TOPICS.values(), topics.COMMAND_TOPIC, topics.REFERENCE_TOPIC,
                   topics.PARAMETERS_TOPIC, topics.DIAGNOSTICS_TOPIC]
        spin_until(executor, lambda: listener.matched(outputs), 60, procs.values())
        procs['plant'] = start([EMLA, 'run', 'plant', '--params-file',
                                params_file(tmp_path, 'plant', duration=PERIODS * 1e-3, start_subscribers=3)])
        spin_until(executor, listener.finished, 120, procs.values())
        wait_exit(procs['plant'])  # it ends by itself after the done signal
        late = []  # a late subscriber gets the latest estimate (transient local)
        node.create_subscription(ParameterEstimate, topics.PARAMETERS_TOPIC, late.append, LATCHED_QOS)
        spin_until(executor, lambda: late, 10)
        for name in others:
            procs[name].send_signal(signal.SIGTERM)
        for name in others:
            wait_exit(procs[name])
    assert topics.stamp_to_ns(late[0].header.stamp) == PERIODS * MS and late[0].samples_used == PERIODS * SAMPLES
    return listener


@pytest.fixture(scope='module')
def runs(tmp_path_factory):
    return [run_graph(tmp_path_factory.mktemp(f'run{k}')) for k in range(2)]


def test_frames_of_every_topic_have_the_size_and_period_of_the_lockstep(runs):
    listener = runs[0]
    for topic in VOLTAGE_TOPICS + STATE_TOPICS:
        frames = listener.frames[topic]
        stamps = [stamp for stamp, _, _ in frames]
        assert {period for _, period, _ in frames} == {1e-4}, topic
        # the plant's true frames and the reference (only recorded) span 10 periods; the controller, a period
        # ahead of the plant (its computational delay), commands the two periods after the end too
        periods = 10 if topic in (*topics.PLANT_TOPICS.values(), topics.REFERENCE_TOPIC) else 1
        extra = 2 if topic in (topics.COMMAND_TOPIC, topics.REFERENCE_TOPIC) else 0
        if topic in VOLTAGE_TOPICS:  # the values over [k Tc + j Ts, k Tc + (j+1) Ts)
            assert stamps == [k * MS for k in range(0, PERIODS + extra, periods)], topic
            assert {len(data) for _, _, data in frames} == {periods * SAMPLES}, topic
        else:  # the state at t = 0, then the states the intervals end on
            assert stamps == [0] + [k * MS + MS // 10 for k in range(0, PERIODS, periods)], topic
            assert [len(data) for _, _, data in frames] == [1] + [periods * SAMPLES] * (PERIODS // periods), topic
    voltage = listener.signal(topics.MEASURED_TOPICS['voltage'])
    np.testing.assert_array_equal(voltage, listener.signal(topics.PLANT_TOPICS['voltage']))
    np.testing.assert_array_equal(voltage, listener.signal(topics.COMMAND_TOPIC)[:-2 * SAMPLES])
    assert np.all(voltage.reshape(PERIODS, SAMPLES) == voltage[::SAMPLES, None])  # held over each period


def test_the_loop_tracks_the_reference_and_the_identifier_sees_aligned_samples(runs):
    listener = runs[0]
    position = listener.signal(topics.PLANT_TOPICS['position'])[:-1]
    error = position - listener.signal(topics.REFERENCE_TOPIC)[:len(position)]
    assert position.max() > 3.5e-3 and np.sqrt(np.mean(error ** 2)) < 1e-4
    stamps = [topics.stamp_to_ns(e.header.stamp) for e in listener.estimates]
    # one estimate per 10 periods, in order, the last one always there; the topic is latched (depth 1), so a
    # listener starved of CPU (the tests run two at a time) may miss a few
    expected = [k * 10 * MS for k in range(1, PERIODS // 10 + 1)]
    assert stamps == sorted(set(stamps)) and set(stamps) <= set(expected) and stamps[-1] == expected[-1]
    assert len(stamps) >= 0.75 * len(expected)
    final = listener.estimates[-1]
    for name, value in TRUTH.items():  # misaligned samples would bias R and L by tens of per cent
        assert getattr(final, name) == pytest.approx(value, rel=0.05), name
    status = listener.diagnostics[-1].status[0]
    assert {kv.key for kv in status.values} == {'excitation', 'covariance_trace', 'samples', 'residual_rms',
                                                'samples_received', 'samples_used', 'samples_lost', 'samples_skipped'}


def test_a_run_done_twice_gives_identical_samples_and_estimates(runs):
    for topic in VOLTAGE_TOPICS + STATE_TOPICS:
        np.testing.assert_array_equal(runs[0].signal(topic), runs[1].signal(topic), err_msg=topic)
    # the estimates by stamp: latched (depth 1), so a listener starved of CPU (the tests run two at a time) may
    # miss a few, as test_launch allows for
    first, second = ({topics.stamp_to_ns(msg.header.stamp): msg for msg in run.estimates} for run in runs)
    common = sorted(set(first) & set(second))
    assert len(common) >= 0.9 * PERIODS // 10
    for stamp in common:
        assert np.array_equal(first[stamp].covariance, second[stamp].covariance, equal_nan=True)
        assert [getattr(first[stamp], name) for name in TRUTH] == [getattr(second[stamp], name) for name in TRUTH]


def test_the_plant_exits_0_on_sigterm_while_it_waits_to_start(tmp_path):
    with ros_node() as (node, executor), processes() as start:
        plant = start([EMLA, 'run', 'plant', '--params-file', params_file(tmp_path, 'plant', start_subscribers=5)])
        spin_until(executor, lambda: ('plant', '/emla') in node.get_node_names_and_namespaces(), 30, [plant])
        plant.send_signal(signal.SIGTERM)
        wait_exit(plant)


def test_the_plant_starts_only_once_its_done_signal_has_a_reader(tmp_path):
    """A reader of /emla/plant/done found after the plant left would never get it: the plant waits for them."""
    with ros_node() as (node, executor), processes() as start:
        ticks = []
        clock = node.create_subscription(Clock, topics.CLOCK_TOPIC, ticks.append, CLOCK_QOS)
        plant = start([EMLA, 'run', 'plant', '--params-file',
                       params_file(tmp_path, 'plant', start_subscribers=0, done_subscribers=1)])
        spin_until(executor, lambda: clock.get_publisher_count(), 30, [plant])
        settle = time.monotonic() + 1.0
        spin_until(executor, lambda: time.monotonic() > settle, 5, [plant])
        assert not ticks                                   # matched, but waiting for a reader of the done signal
        node.create_subscription(Time, topics.DONE_TOPIC, lambda msg: None, LATCHED_QOS)
        spin_until(executor, lambda: ticks, 30, [plant])
        assert topics.stamp_to_ns(ticks[0].clock) == 0     # started: the state at t = 0 and /clock = 0
        plant.send_signal(signal.SIGTERM)
        wait_exit(plant)


def test_declared_parameters_have_descriptors_and_the_yaml_defaults(monkeypatch):
    monkeypatch.setenv('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    rclpy.init(domain_id=int(isolated_env()['ROS_DOMAIN_ID']))
    try:
        for name, node_class in NODE_CLASSES.items():
            node = node_class()
            defaults = yaml.safe_load(CONFIG[name].read_text())[f'/emla/{name}']['ros__parameters']
            names = set(node.list_parameters([], 0).names) - RCLPY_PARAMETERS
            declared = {n: node.get_parameter_or(n, Parameter(n)) for n in names}
            assert set(declared) == set(defaults), name
            for parameter_name, parameter in declared.items():
                descriptor = node.describe_parameter(parameter_name)
                assert descriptor.description and descriptor.read_only, parameter_name
                ranges = [*descriptor.floating_point_range, *descriptor.integer_range]
                numeric = descriptor.type in (Parameter.Type.DOUBLE.value, Parameter.Type.INTEGER.value)
                assert len(ranges) == numeric, parameter_name
                value = [] if parameter.type_ == Parameter.Type.NOT_SET else parameter.value
                assert value == defaults[parameter_name], parameter_name
            node.destroy_node()
    finally:
        rclpy.try_shutdown()


@pytest.mark.parametrize('args, message', [
    (['run', 'pump'], "unknown node 'pump'"),
    (['run', 'plant', '--params-file', '/nonexistent.yaml'], '/nonexistent.yaml: no such params file'),
])
def test_emla_run_refuses_an_unknown_node_or_params_file(args, message):
    result = subprocess.run([EMLA, *args], capture_output=True, text=True, timeout=60, env=isolated_env())
    assert result.returncode == 2 and result.stderr.count('\n') == 1 and message in result.stderr


def test_a_bad_parameter_ends_the_node_with_one_line(tmp_path):
    result = subprocess.run([EMLA, 'run', 'plant', '--params-file', params_file(tmp_path, 'plant', resistance=-1.0)],
                            capture_output=True, text=True, timeout=60, env=isolated_env())
    assert result.returncode == 2 and result.stderr.count('\n') == 1 and 'resistance' in result.stderr
