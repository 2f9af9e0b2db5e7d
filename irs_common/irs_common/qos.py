"""QoS profiles by role, one place for the whole graph (see docs/architecture.md).

- ``SENSOR``: 1 kHz measurement streams (arm angles, belt speed, pose, ...). RELIABLE, KEEP_LAST
  100, VOLATILE. On a hardware rig such streams are often best effort; we choose reliable because
  the lock-step simulation and the recorder must not lose a sample (a lost sample would stall
  lock-step or leave a hole in a bag). A best-effort subscriber still matches these publishers.
  Depth 100 = 0.1 s of history at 1 kHz absorbs scheduling hiccups on a loaded machine.
- ``COMMAND``: actuator commands (steer, drive voltage, driver speed). RELIABLE, KEEP_LAST 100,
  VOLATILE: each command belongs to one step in lock-step, so none may be dropped.
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
CLOCK = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                   reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
