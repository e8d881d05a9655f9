"""Input faults of a node (a lost, empty, non-finite or wrong-period frame, a stamp that jumps back; the
identifier's 'unestimable': frames that leave no estimate computable, e.g. an overflow): counted, logged and
published on /diagnostics."""
import collections

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from emla_core.nodes.qos import DIAGNOSTICS_QOS
from emla_core.topics import DIAGNOSTICS_TOPIC


class Faults:
    """A node's input faults (a lost frame, an empty one, ...) counted by kind: each is logged as a warning (at
    most one line per WARNING_INTERVAL s: a burst does not flood the log), and within a second of a new one
    the counts go to /diagnostics, one status 'emla/<node>/input' of level WARN with a KeyValue per kind."""

    WARNING_INTERVAL = 5.0  # s

    def __init__(self, node):
        self._node = node
        self.counts = collections.Counter()
        self._published = 0  # total of the counts on /diagnostics
        self._diagnostics = node.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC, DIAGNOSTICS_QOS)
        node.create_timer(1.0, self._publish)

    def report(self, kind, message):
        self.counts[kind] += 1
        self._node.get_logger().warning(f'{message} (input faults so far: {self._summary()})',
                                        throttle_duration_sec=self.WARNING_INTERVAL)

    def _summary(self):
        return ', '.join(f'{count} {kind}' for kind, count in sorted(self.counts.items()))

    def _publish(self):
        if self.counts.total() == self._published:
            return
        self._published = self.counts.total()
        status = DiagnosticStatus(level=DiagnosticStatus.WARN, name=f'emla/{self._node.get_name()}/input',
                                  hardware_id='emla', message=f'input faults: {self._summary()}',
                                  values=[KeyValue(key=kind, value=str(count))
                                          for kind, count in sorted(self.counts.items())])
        array = DiagnosticArray(status=[status])
        array.header.stamp = self._node.get_clock().now().to_msg()
        self._diagnostics.publish(array)
