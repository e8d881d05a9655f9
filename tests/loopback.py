"""Ports on 127.0.0.1 for the tests that start a dask scheduler of their own."""
import socket
import time


def free_port():
    """A TCP port of 127.0.0.1 free at the moment."""
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def wait_for_port(port, timeout):
    """Return once something listens on 127.0.0.1:`port`; TimeoutError after `timeout` s."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        with socket.socket() as s:
            if s.connect_ex(('127.0.0.1', port)) == 0:
                return
        time.sleep(0.1)
    raise TimeoutError(f'no scheduler on port {port} after {timeout} s')
