"""The offline twin of the graph: the same cores composed into one ROS-free simulation.

:mod:`.lateral_loop` (:class:`~.lateral_loop.ClosedLoop`: the Figure 10 graph - rig,
estimator, reference, lateral controller, treadmill regulator, driver), :mod:`.chassis_loop`
(:class:`~.chassis_loop.ChassisLoop`: the torque car's graph) and :mod:`.from_experiment` (an
experiment file's parameters for either, and its run). Each core is configured from the same
parameter table as its node (``*_params.py``: ``node_only`` parameters left out), so an
experiment file drives the graph and the twin alike, and a lock-step graph run reproduces the
twin's numbers to the bit (``irs_system_tests``).
"""
