"""EmlaNode: the base of the suite's nodes (finishing, failing, polling outside the loop, stopping once
its readers acknowledged what it published)."""
import time

from rclpy.duration import Duration
from rclpy.node import Node

ACK_TIMEOUT = 4.0  # s a stopping node waits for its readers' acknowledgements


class EmlaNode(Node):
    """A node of the suite (namespace /emla); it ends the process when `finished` becomes true (with exit
    status 2 after fail()).

    POLL_PERIOD: None for a node that handles each message as it comes (the loop's); for one outside the loop,
    a period (s): it handles every POLL_PERIOD what came meanwhile, its readers keeping the messages until
    then. A wake-up costs a process more than handling a message, and that way it wakes 1/POLL_PERIOD times a
    second, not once per message."""

    NAME = ''
    POLL_PERIOD: float | None = None

    def __init__(self):
        super().__init__(self.NAME, namespace='/emla')
        self.finished = False
        self.error = None
        self.handled = 0  # messages its subscriptions handled

    def create_subscription(self, msg_type, topic, callback, *args, **kwargs):
        """Node.create_subscription, counting the messages handled in `handled`."""
        def counted(msg):
            self.handled += 1
            callback(msg)
        return super().create_subscription(msg_type, topic, counted, *args, **kwargs)

    def ready(self):
        """What `run` says once the node is constructed: the topics it subscribed to and publishes."""
        subscribed = ', '.join(dict.fromkeys(s.topic_name for s in self.subscriptions)) or 'nothing'
        published = ', '.join(dict.fromkeys(p.topic_name for p in self.publishers
                                            if p.topic_name != '/parameter_events')) or 'nothing'
        return f'subscribed to {subscribed}; publishing {published}'

    def fail(self, message):
        """End the node for bad input found while it runs: `message` as its one line, exit status 2."""
        self.error, self.finished = message, True

    def spin(self, executor):
        """One turn of the spin loop of `run`: handle the next event (waiting for one at most 0.05 s); with a
        POLL_PERIOD, wait that long, then handle the messages that came."""
        if self.POLL_PERIOD is None:
            executor.spin_once(timeout_sec=0.05)
            return
        time.sleep(self.POLL_PERIOD)
        handled = None
        while handled != self.handled:  # one event (a subscription's messages, a timer) per spin_once
            handled = self.handled
            executor.spin_once(timeout_sec=0)

    def stop(self, executor):
        """Called once the spin loop of `run` ends: wait until readers acknowledged what was published."""
        wait_for_acknowledgements(self)


def wait_for_acknowledgements(node, timeout=ACK_TIMEOUT):
    """Wait (at most `timeout` s) until every reader acknowledged what `node` published: a reader that must
    have a message resent (a recorder behind) would lose it once the node is gone. Fast DDS learns of the
    acknowledgements at its next heartbeat, so this takes up to ~3 s."""
    deadline = time.monotonic() + timeout
    for publisher in node.publishers:
        publisher.wait_for_all_acked(Duration(seconds=max(0.0, deadline - time.monotonic())))
