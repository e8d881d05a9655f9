"""The suite's ROS 2 nodes and what they share; below, the graph they form: topics and QoS, the lockstep,
the done signal, bad frames, standard input topics, and what every node does.

Modules: qos (profiles), fastdds (the Fast DDS profile, fastdds.xml), faults (input faults on /diagnostics),
frames (frame topics, FrameSets), alignment (AlignedSamples), standard_topics (StandardTopics),
param_specs (declared parameters), params_file (params files checked), node (EmlaNode), run (a node as a
process, helper nodes); recorder_node (the recorder).

Graph (namespace /emla, SI units). A SampleFrame holds consecutive samples of one signal, stamped with the
simulated time of its first sample; the frames of control period k (Tc = n Ts, k = 0, 1, ...) are:
  voltage frames (/emla/voltage, /emla/voltage_command): the n values over [k Tc + j Ts, k Tc + (j+1) Ts),
    j = 0..n-1, stamp k Tc;
  state frames (/emla/{current,position}): the n samples the period's voltage intervals end on, at
    k Tc + (j+1) Ts, stamp k Tc + Ts; so the state at (k+1) Tc is the last sample of period k's frame. Before
    period 0 the plant publishes one state frame of a single sample: the state at t = 0, stamp 0.
Frames only a recorder reads (the plant's truth /emla/plant/{voltage,current,position}, /emla/reference) span
10 periods alike (the plant's parameters_period, the controller's REFERENCE_FRAME): fewer, longer messages cost
every process less (a delivery costs a process a wake-up, some 0.1 ms here). The plant's truth of each period
goes to the sensor in one message, a SignalFrames on /emla/plant/frames.
Aligned by stamp (as emla_core.bag.read_bag does), the state samples at t_j pair with the voltage held over
[t_j, t_j + Ts), the Recording convention; alignment.AlignedSamples does this for a node.

| topic                                  | type                            | publisher  | QoS     |
|----------------------------------------|---------------------------------|------------|---------|
| /emla/plant/frames                     | emla_msgs/SignalFrames (truth)  | plant      | FRAME   |
| /emla/plant/{voltage,current,position} | emla_msgs/SampleFrame (truth)   | plant      | FRAME   |
| /emla/plant/parameters                 | emla_msgs/ParameterEstimate     | plant      | FRAME   |
| /emla/plant/done                       | builtin_interfaces/Time         | plant      | LATCHED |
| /clock                                 | rosgraph_msgs/Clock             | plant      | CLOCK   |
| /emla/{voltage,current,position}       | emla_msgs/SampleFrame (measured)| sensor     | FRAME   |
| /emla/voltage_command, /emla/reference | emla_msgs/SampleFrame           | controller | FRAME   |
| /emla/parameters                       | emla_msgs/ParameterEstimate     | identifier | LATCHED |
| /emla/arx_model (instead, model arx)   | emla_msgs/ArxModel              | identifier | LATCHED |
| /diagnostics                           | diagnostic_msgs/DiagnosticArray | identifier*| DIAGNOSTICS |
FRAME: reliable, transient local, keep last 1000 (1 s of default frames: a reader outside the loop, such as a
non-adaptive controller's identifier or a recorder, may lag that much without losing frames; the true parameters,
which change every 1 ms in a ramp, are kept so too);
LATCHED: reliable, transient local, keep last 1 (a late subscriber gets the latest);
CLOCK: best effort, volatile, keep last 1 (as rclpy's time source subscribes); DIAGNOSTICS: reliable, 10.
*and the sensor's and controller's input faults (see Bad frames).
The nodes publish and read frames as serialised bytes (emla_core.messages.frame_cdr, read_frame_cdr: no rclpy
message built), and run with the suite's Fast DDS profile (fastdds.xml, see fastdds.py: writers send no
heartbeat with every sample nor fire a timer per sample and reader, participants announce themselves often
while the graph starts), which spares each process wake-ups and a launch seconds of discovery.

Deterministic lockstep in simulated time, the controller one period ahead of the plant:
1. Start: once /emla/position has `start_subscribers` subscriptions (the plant's parameter: controller,
   identifier, recorders: whoever must see every frame), /emla/plant/done has `done_subscribers` (identifier,
   recorders, a launcher: whoever must learn the end) and, with start_subscribers > 0, the plant's frames
   and its commands are matched (the sensor, the controller), the plant publishes the state at t = 0. The
   controller and identifier subscribe to /emla/position only once their other frame topics have a matched
   publisher (frames.subscribe_frames), so the loop's first frames do not wait for a late discovery.
2. Sensor: measures the state frames of each plant message and publishes them with the same stamp; the
   voltage frame passes unchanged to /emla/voltage.
3. Controller: from the last sample of each measured state frame (time t = stamp + (size - 1) Ts) it computes
   the command for the period starting at t + Tc (n equal values, stamp t + Tc), predicting the state there
   from its model under the command of the period from t, which it published a period earlier: one period
   of computational delay, as any digital controller has, so that it computes while the plant runs. From the
   first state (t = 0) it commands the period from t = 0 too, with the law's voltage there. Its commands for
   the two periods after the end go unused.
4. Plant: advances period k only with the command stamped k Tc in hand; publishes its frames (to the sensor),
   then /clock = (k+1) Tc. It holds the command for period k+1 by the end of period k unless the loop
   (plant -> sensor -> controller -> plant, three deliveries) takes longer than a period of the plant's.
5. Identifier: feeds the aligned samples in time order to the estimator and publishes /emla/parameters (in
   ARX mode /emla/arx_model) at every multiple of `publish_period` that ends a period, stamped with the END of
   the data it covers: the estimate stamped t has used every voltage interval before t. An adaptive controller
   (its `adaptation_period` Ta is a multiple of that publish_period) takes the estimate stamped t at the next
   adaptation instant, before the command it computes at t + Ta (waiting for it if need be): the identifier
   has a whole adaptation period to deliver it, so the loop does not wait for its computation. Lag: the
   command held from t + Ta + Tc on uses the estimate from all the data before t, so a plant change reaches
   the model up to two adaptation periods later (plus the estimator's own memory; the in-process loop,
   emla_bench.loop, has neither the computational delay nor this adaptation period of lag).
Every message travels on a reliable, in-order topic and each node computes from its inputs alone, so a run's
samples do not depend on scheduling. Frames are transient local so that a reader that matches a publisher
late (start-up) still gets them; in the loop, at most two periods' messages are in flight.

Done signal: with duration > 0 the plant advances round(duration / Tc) periods, publishes the final frames,
the final true parameters and /emla/plant/done (builtin_interfaces/Time: the end time, latched), and exits 0
once every reader acknowledged its messages (see node.wait_for_acknowledgements). The identifier then
publishes its final estimate stamped with that end time (if that was not a publishing instant anyway): the last
/emla/parameters message covers every sample the plant produced. A launcher waits for it, then stops the
other nodes with SIGTERM.

Bad frames (a real sensor stream loses some): the sensor, controller and identifier keep running through lost,
empty, non-finite and wrong-period frames and stamps that jump back; each such fault is a warning in the log and
a count on /diagnostics (faults.Faults; frames.FrameSets and alignment.AlignedSamples find them and
resynchronise). The sensor publishes empty frames for a period whose plant frames it cannot use (non-finite
samples it measures as they are); the controller holds its last voltage over the period after a state it lacks
and publishes it, so the lockstep goes on (it does not wait for an estimate then); the identifier skips the
instants it lacks usable samples for, and none of its regression rows spans them. A frame lost outright inside
the lockstep stalls it: the next one needs the command it would have led to.

Standard topics: the identifier can read a real drive's topics of standard message types instead of the measured
frames (its input_topics; standard_topics.StandardTopics): each message becomes a frame on the sample grid (by
its header stamp, else its receive time), so the same faults are found and survived.

Each node: parameters declared read-only with descriptors (range, units in the description), defaults in the
package's config/<node>.yaml; once constructed (warmed up, subscribed) it says 'NAME: ready (its topics)' on
stderr; SIGINT/SIGTERM end it cleanly with exit status 0 (after the acknowledgements of what it published, at
most ACK_TIMEOUT); bad parameters (out of range, of another type, or not the node's: a params file's typo, see
params_file) end it with one line on stderr and exit status 2, as does bad input found later (node.EmlaNode.fail: an
input topic of a type it cannot read).
"""
