"""MCAP bags: the reader/writer library, the recorder node and the ``bag`` tools.

Library: :mod:`.bag_reader` (indexed reads, recovery of truncated bags), :mod:`.bag_scan`
(sequential scan), :mod:`.bag_validate`, :mod:`.bag_writer`, :mod:`.msg_definitions`.
Node: :mod:`.recorder_node` (``recorder``). Tools behind ``bag`` (:mod:`.bag_cli`): info,
export, play, plots, rerun, recover; :mod:`.bench_replay` measures replay throughput.
"""
