"""AlignedSamples: the samples all frame topics have at the same instants, in time order and in chunks,
in the Recording convention (an estimator's input)."""
import itertools

import numpy as np

from emla_core.nodes.frames import FrameSets, subscribe_frames
from emla_core.topics import to_ns


class AlignedSamples:
    """Subscribes to frame topics {name: topic} of one sample period and calls on_samples(start_ns, {name:
    array}) with the samples all of them have at the same instants, in time order, in chunks that end at the
    multiples of `boundary` (ns): a chunk is passed on once all have the samples up to the next multiple, or
    up to a gap, or up to the end of the input (finish()). Few long chunks: an estimator's update costs about
    as much per call as for a hundred samples. The graph's frames (state frames one sample later than voltage
    frames) come out in the Recording convention, the estimator's input: the state samples where each voltage
    interval starts. Frames aligned already (a bag of `emla simulate` played) pass as they are.

    Instants some topic has no samples for (lost or unusable frames, see FrameSets; faults reported there)
    are skipped: the next chunk starts later than the last one ended, at the first instant all have again.
    Non-finite samples are passed on, in place. With subscribe=False the frames come through receive()
    (see FrameSets)."""

    def __init__(self, node, topics, on_samples, faults, sample_period, boundary, subscribe=True):
        self._on_samples = on_samples
        self._step = to_ns(sample_period)
        self._boundary = boundary
        self._finish = None  # the end of the input, once known
        self._cursor = None  # the first instant not passed on (or skipped) yet
        self._queues = {name: [] for name in topics}  # name -> [(stamp, samples)] not passed on yet
        self._frames = {name: FrameSets(node, {name: topic}, self._on_set, faults, sample_period, subscribe=False)
                        for name, topic in topics.items()}
        if subscribe:
            subscribe_frames(node, topics, lambda name, cdr: self._frames[name].receive_cdr(name, cdr))

    @property
    def names(self):
        """The inputs' names."""
        return tuple(self._queues)

    def receive(self, name, stamp, samples, period):
        """A frame of input `name` (see FrameSets.receive)."""
        self._frames[name].receive(name, stamp, samples, period)

    def finish(self, end):
        """The input ends at `end` (ns): pass on the samples up to it without waiting for a multiple of boundary."""
        self._finish = end
        self._pass_on()

    def _on_set(self, stamp, sample_period, frames):
        if frames is None:
            return  # an unusable frame: its instants will be skipped
        ((name, samples),) = frames.items()
        self._queues[name].append((stamp, samples))
        self._pass_on()

    def _pass_on(self):
        while True:
            if self._cursor is not None:
                for queue in self._queues.values():  # drop what the cursor skipped
                    while queue and self._end(queue[0]) <= self._cursor:
                        queue.pop(0)
            if not all(self._queues.values()):
                return
            resume = max(queue[0][0] for queue in self._queues.values())
            if self._cursor is None or resume > self._cursor:
                self._cursor = resume  # the start, or a skip over instants some topic lacks
                continue
            boundary = (self._cursor // self._boundary + 1) * self._boundary
            ends = {name: self._contiguous_end(queue) for name, queue in self._queues.items()}
            end = min(boundary, *ends.values())
            if end < boundary and end != self._finish and \
                    all(self._end(self._queues[name][-1]) == ends[name] for name in ends if ends[name] == end):
                return  # the samples after `end` are still to come (no gap there)
            chunk = {name: self._take(queue, end) for name, queue in self._queues.items()}
            start, self._cursor = self._cursor, end
            self._on_samples(start, chunk)

    def _end(self, frame):
        stamp, samples = frame
        return stamp + len(samples) * self._step

    def _contiguous_end(self, queue):
        """The end of the queued samples that follow on from the first frame without a gap."""
        end = self._end(queue[0])
        for stamp, samples in itertools.islice(queue, 1, None):  # (_end inline: called for every frame queued)
            if stamp != end:
                break
            end = stamp + len(samples) * self._step
        return end

    def _take(self, queue, end):
        """The queued samples at the instants [cursor, end); later ones stay queued."""
        parts = []
        while queue and queue[0][0] < end:
            stamp, samples = queue[0]
            first, last = max(0, (self._cursor - stamp) // self._step), (end - stamp) // self._step
            parts.append(samples[first:last])
            if last < len(samples):
                queue[0] = (stamp + last * self._step, samples[last:])
                break
            queue.pop(0)
        return parts[0] if len(parts) == 1 else np.concatenate(parts)
