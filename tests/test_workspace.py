"""The workspace: messages importable, a ParameterEstimate crosses processes, colcon builds the packages."""
import subprocess
import sys

import pytest
from ros_isolation import REPO, VENV_BIN, isolated_env, processes

PUBLISHER = r'''
import time, rclpy
from rclpy.qos import QoSProfile, DurabilityPolicy, ReliabilityPolicy
from emla_msgs.msg import ParameterEstimate
rclpy.init()
node = rclpy.create_node('test_publisher')
qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
pub = node.create_publisher(ParameterEstimate, '/emla/parameters', qos)
msg = ParameterEstimate(resistance=4.0, inductance=1.6e-3, emf_constant=10.8, mass=0.036, damping=2.0,
                        load_force=-1.5, samples_used=1234)
end = time.monotonic() + 30
while time.monotonic() < end:
    pub.publish(msg)
    rclpy.spin_once(node, timeout_sec=0.1)
'''

SUBSCRIBER = r'''
import time, rclpy
from rclpy.qos import QoSProfile, DurabilityPolicy, ReliabilityPolicy
from emla_msgs.msg import ParameterEstimate
rclpy.init()
node = rclpy.create_node('test_subscriber')
qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
got = []
node.create_subscription(ParameterEstimate, '/emla/parameters', got.append, qos)
end = time.monotonic() + 25
while not got and time.monotonic() < end:
    rclpy.spin_once(node, timeout_sec=0.1)
m = got[0]
print(m.resistance, m.inductance, m.emf_constant, m.mass, m.damping, m.load_force, m.samples_used)
'''


def test_messages_import_in_the_venv():
    out = subprocess.run([sys.executable, '-c', 'from emla_msgs.msg import ParameterEstimate, SampleFrame, '
                          'ArxModel; print(SampleFrame().sample_period, ParameterEstimate().std.shape)'],
                         capture_output=True, text=True, timeout=60, check=True)
    assert out.stdout.split() == ['0.0', '(6,)']


def test_parameter_estimate_crosses_processes():
    with processes() as start:
        start([sys.executable, '-c', PUBLISHER])
        sub = start([sys.executable, '-c', SUBSCRIBER])
        out, err = sub.communicate(timeout=60)
    assert sub.returncode == 0, err
    assert [float(v) for v in out.split()] == [4.0, 1.6e-3, 10.8, 0.036, 2.0, -1.5, 1234]


@pytest.mark.timeout(300)
def test_colcon_builds_the_workspace(tmp_path):
    venv = VENV_BIN.parent
    env = isolated_env(AMENT_PREFIX_PATH=venv, CMAKE_PREFIX_PATH=venv,
                       PATH=f'{VENV_BIN}:{isolated_env()["PATH"]}')
    result = subprocess.run(
        [str(VENV_BIN / 'colcon'), '--log-base', str(tmp_path / 'log'), 'build', '--base-paths', str(REPO),
         '--build-base', str(tmp_path / 'build'), '--install-base', str(tmp_path / 'install'),
         '--cmake-args', f'-DPython3_EXECUTABLE={sys.executable}', '-DBUILD_TESTING=OFF'],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=280)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    install = tmp_path / 'install'
    indexed = {p.name for p in install.glob('*/share/ament_index/resource_index/packages/*')}
    assert {'emla_msgs', 'emla_core', 'emla_sim', 'emla_identification', 'emla_control', 'emla_bench',
            'emla_cli'} <= indexed
    for pkg, exe in [('emla_sim', 'plant'), ('emla_sim', 'sensor'), ('emla_identification', 'identifier'),
                     ('emla_core', 'recorder'),
                     ('emla_control', 'controller')]:
        assert (install / pkg / 'lib' / pkg / exe).is_file(), f'{pkg} {exe} not where ros2 run looks'
