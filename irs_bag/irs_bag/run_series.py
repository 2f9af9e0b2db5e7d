"""Time series of an experiment run, taken from its bag (no rclpy).

``lateral_run(bag)`` gives the arrays the Figure 10 report and the offline comparison use, indexed
by the rig's step stamps: ``time`` [s], ``y_s`` (ground truth, m), ``y_measured`` (sensed, m),
``reference`` [m], ``steer_cmd`` and ``steer_achieved`` [rad], ``x`` [m], ``belt_speed`` [m/s],
``drive_voltage`` [V]. A stamp missing on a topic gives NaN there.
"""
from operator import attrgetter

import numpy as np

from .reader import BagReader

# topic -> {series name: attribute path}
SERIES = {
    '/ground_truth/sensor_point': {'y_s': 'point.y'},
    '/lateral_position': {'y_measured': 'point.y'},
    '/lateral/reference': {'reference': 'lateral_position'},
    '/steering/command': {'steer_cmd': 'front_angle'},
    '/steering/state': {'steer_achieved': 'front_achieved'},
    '/ground_truth/odom': {'x': 'pose.pose.position.x'},
    '/belt/speed': {'belt_speed_measured': 'speed'},
    '/treadmill/drive': {'drive_voltage': 'voltage'},
}


def _stamp_ns(msg) -> int:
    s = msg.header.stamp
    return int(s.sec) * 1_000_000_000 + int(s.nanosec)


def series_by_stamp(bag_path, series=None) -> dict:
    """``{series name: {stamp_ns: value}}`` for the topics present in the bag."""
    series = series or SERIES
    getters = {topic: [(name, attrgetter(path)) for name, path in fields.items()]
               for topic, fields in series.items()}
    out = {}
    with BagReader(bag_path) as reader:
        topics = [t for t in series if t in reader.topics]
        for m, msg in reader.decoded(topics):
            for name, get in getters[m.topic]:
                out.setdefault(name, {})[_stamp_ns(msg)] = float(get(msg))
    return out


def lateral_run(bag_path) -> dict:
    """Arrays on the common stamp grid of the ground-truth topic (see module docstring)."""
    data = series_by_stamp(bag_path)
    if 'y_s' not in data:
        raise ValueError(f'{bag_path}: no /ground_truth/sensor_point messages')
    stamps = np.array(sorted(data['y_s']), dtype=np.int64)
    run = {'time': stamps * 1e-9}
    for name, values in data.items():
        run[name] = np.array([values.get(int(s), np.nan) for s in stamps], dtype=float)
    return run
