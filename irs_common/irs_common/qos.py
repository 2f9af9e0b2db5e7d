"""QoS profiles by role, one place for the whole graph (see docs/architecture.md).

- ``SENSOR``: 1 kHz measurement streams (arm angles, belt speed, pose, ...). RELIABLE, KEEP_LAST
  100, VOLATILE. On a hardware rig such streams are often best effort; we choose reliable because
  the lock-step simulation and the recorder must not lose a sample (a lost sample would stall
  lock-step or leave a hole in a bag). A best-effort subscriber still matches these publishers.
  Depth 100 = 0.1 s of history at 1 kHz absorbs scheduling hiccups on a loaded machine.
- ``COMMAND``: actuator commands (steer, drive voltage, driver speed). RELIABLE, KEEP_LAST 100,
  VOLATILE: each command belongs to one step in lock-step, so none may be dropped.
- ``SENSOR_PUB`` / ``COMMAND_PUB``: the same for the *publishers*, with a history of
  ``PUBLISHER_HISTORY`` = 5000 samples (5 s at 1 kHz). A reliable writer keeps unacknowledged
  samples only as deep as its history, so a reader starved of CPU for longer loses them for good;
  5000 lets a recorder stall for 2 s without loss (measurements: docs/performance.md). The cost is
  memory (up to 5000 samples of a few hundred bytes per publisher); a subscription's own depth
  stays 100, so a node that catches up after a stall is not fed 5 s of stale samples.
- ``STATUS``: low-rate health/fault messages, for a subscriber that wants the current state.
  RELIABLE, KEEP_LAST 1, TRANSIENT_LOCAL (latched): a late joiner sees the current fault at once.
- ``STATUS_PUB``: the status *publishers*: the same, with a history of ``STATUS_HISTORY`` = 100
  messages. A reliable writer replaces a sample its readers have not acknowledged once its
  history is full; with a history of 1, a transition followed within a few milliseconds by the
  next status (the rig's ``HOLDING`` then ``STOPPING``) never reached a recorder that was short
  of CPU, and the bag lacked the transition. 100 covers 10 s of the rig's 10 Hz status plus its
  transitions. A late joiner receives that history; ``STATUS``'s depth 1 keeps what it has not
  yet taken to the newest, and a reader that wants only what comes after it joined subscribes
  ``STATUS_LIVE``.
- ``STATUS_LIVE``: a status subscriber that wants what is published from the moment it joins,
  not the history (``rig/recover``'s caller, :mod:`irs_vehicle_sim.recover_call`, must not take
  an old ``SAFE_RUNNING`` for its answer). RELIABLE, KEEP_LAST 10, VOLATILE.
- ``CLOCK``: /clock from the lock-step rig. RELIABLE, KEEP_LAST 100 for nodes that act on every
  tick (the reference generator); rclpy's own time source subscribes best effort, depth 1, which
  matches. ``CLOCK_PUB``, the rig's publisher, keeps ``PUBLISHER_HISTORY`` like ``SENSOR_PUB``:
  the rig steps at the pace of its controller, not of a recorder of ``/clock``.
"""
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

SENSOR = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
COMMAND = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                     reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
STATUS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                    reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: History of a status publisher [messages] (module docstring).
STATUS_HISTORY = 100
STATUS_PUB = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=STATUS_HISTORY,
                        reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)
STATUS_LIVE = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)
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
CLOCK_PUB = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=PUBLISHER_HISTORY,
                       reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.VOLATILE)
