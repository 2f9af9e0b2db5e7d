"""The paper's analysis, without rclpy: the offline closed loop and Figure 10.

:mod:`.closed_loop` (the graph's cores as one offline simulation), :mod:`.run_series` (the
arrays of a recorded run), :mod:`.figure10` (metrics and report), :mod:`.figure10_study`
(conditions and step sizes), :mod:`.regulation_metrics` (treadmill regulation phases).
"""
