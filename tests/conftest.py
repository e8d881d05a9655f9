"""Fixtures shared by the test modules."""
import pytest
from ros_isolation import isolated_env

from emla_cli.launcher import reserved_domain


@pytest.fixture
def ros_env():
    """The environment of a ROS domain no other launch or test uses meanwhile (locked), for one test."""
    with reserved_domain() as domain:
        yield isolated_env(ROS_DOMAIN_ID=domain)
