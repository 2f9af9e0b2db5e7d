"""QoS profiles by role, one place for the whole graph (see docs/architecture.md).

- ``SENSOR``: 1 kHz measurement streams (arm angles, belt speed, pose, ...). RELIABLE, KEEP_LAST
  100, VOLATILE. On a hardware rig such streams are often best effort; we choose reliable because
  the lock-step simulation and the recorder must not lose a sample (a lost sample would stall
  lock-step or leave a hole in a bag). A best-effort subscriber still matches these publishers.
  Depth 100 = 0.1 s of history at 1 kHz absorbs scheduling hiccups on a loaded machine.
- ``COMMAND``: actuator commands (steer, drive voltage, driver speed). RELIABLE, KEEP_LAST 100,
  VOLATILE: each command belongs to one step in lock-step, so none may be dropped.
- ``SENSOR_PUB`` / ``COMMAND_PUB``: the same for the *publishers* of those streams, with a history
  of ``PUBLISHER_HISTORY`` = 5000 samples (5 s at 1 kHz). A reliable writer keeps the samples a
  reader has not acknowledged only as deep as its history: a reader that falls further behind
  (a recorder at normal priority starved of CPU by SCHED_FIFO nodes) loses them for good, because
  they can no longer be repaired. With 100, a recorder frozen for 0.3 s (``SIGSTOP``) lost 21,061
  messages in a 30 s process-per-node run at 1 kHz, and the 10-minute soak lost 9,049 on a quiet
  machine and 94,473 on a busy one; with 1000, a 0.3 s or 0.8 s freeze lost none and a 2 s freeze
  lost 3,097; with 5000, a 2 s freeze lost none and a 4 s one 6,950, and three soaks lost none
  (issue 9, stop 20; docs/performance.md). The cost is memory, up to 5000 samples of a few
  hundred bytes per publisher; no CPU cost could be measured. A subscription's own depth stays
  100: a node that catches up after a stall is not fed 5 s of stale samples.
- ``STATUS``: low-rate health/fault messages. RELIABLE, KEEP_LAST 1, TRANSIENT_LOCAL (latched):
  a late joiner sees the current fault at once.
- ``CLOCK``: /clock from the lock-step rig. RELIABLE, KEEP_LAST 100 for nodes that act on every
  tick (the reference generator); rclpy's own time source subscribes best effort, depth 1, which
  matches.
"""
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

SENSOR = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
COMMAND = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                     reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
STATUS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                    reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: History of a 1 kHz publisher [samples]: how far a reliable reader may fall behind without loss
#: (5 s at 1 kHz; the 10-minute soak saw recorder stalls of up to 5.4 s on a busy machine).
PUBLISHER_HISTORY = 5000
SENSOR_PUB = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=PUBLISHER_HISTORY,
                        reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.VOLATILE)
COMMAND_PUB = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=PUBLISHER_HISTORY,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)
CLOCK = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                   reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
