"""Fixtures shared by the test modules."""
import pytest

from emla_cli.launcher import reserved_domain
from ros_isolation import isolated_env


@pytest.fixture
def ros_env():
    """The environment of a ROS domain no other launch or test uses meanwhile (locked), for one test."""
    with reserved_domain() as domain:
        yield isolated_env(ROS_DOMAIN_ID=domain)
