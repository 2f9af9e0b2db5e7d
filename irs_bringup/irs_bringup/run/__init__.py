"""Running experiments: experiment files, their schema, node processes and the runner.

:mod:`.experiment` and :mod:`.experiment_schema` (the file format and its checks),
:mod:`.executables` and :mod:`.processes` (starting the nodes), :mod:`.graph` (watching the
graph), :mod:`.experiment_runner` (the ROS run), :mod:`.offline` (an experiment as an offline
:class:`~irs_bringup.paper.closed_loop.LoopConfig`), :mod:`.container` (composition),
:mod:`.experiment_cli` (``experiment``) and :mod:`.param_docs` (docs/parameters.md).
"""
