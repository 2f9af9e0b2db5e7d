"""Parameter table of the ``live_view`` node (no rclpy)."""
from irs_common.params import Param

#: The topics the entities are made of (irs_bag.rerun_entities.SPEC), relative names.
TOPICS = ['ground_truth/odom', 'pose', 'arm/joint_states', 'ground_truth/sensor_point',
          'lateral_position', 'lateral/reference', 'steering/command', 'steering/state',
          'belt/speed', 'treadmill/state']

#: The default: the topics no node of the loop reads. A topic that an outside process subscribes
#: to goes through DDS for the loop's own nodes too (no in-process handover), which in a composed
#: real-time run raised the control latency from about 0.5 ms to 50 ms (docs/plots.md).
OUTSIDE_THE_LOOP = ['ground_truth/odom', 'ground_truth/sensor_point', 'steering/state',
                    'treadmill/state']


def _known_topics(value):
    bad = [t for t in value if t not in TOPICS]
    return f"not topics of the view: {', '.join(bad)} (known: {', '.join(TOPICS)})" if bad \
        else None

#: rerun's default gRPC URL: a viewer started with ``rerun`` on this machine.
DEFAULT_URL = 'rerun+http://127.0.0.1:9876/proxy'
#: The Foxglove app's default WebSocket connection.
FOXGLOVE_URL = 'ws://127.0.0.1:8765'


def _ws_url(value):
    if value == '':
        return None
    from .foxglove_bridge import parse_ws_url
    try:
        parse_ws_url(value)
    except ValueError as exc:
        return str(exc)
    return None

NODE_PARAMS = [
    Param('topics', OUTSIDE_THE_LOOP, 'topics to show, any of the run.rrd topics (the default: '
          'those no loop node reads; each other one takes the in-process handover off that '
          'topic)', '-', read_only=True,
          validator=_known_topics),
    Param('url', DEFAULT_URL, "rerun viewer to stream to (its gRPC proxy URL; '' = none)", '-',
          read_only=True),
    Param('save', '', "write an .rrd file here instead of streaming to 'url' ('' = stream)",
          '-', read_only=True),
    Param('foxglove', '', 'serve the topics to the Foxglove app on a WebSocket at this URL '
          f"(ws://host:port, e.g. {FOXGLOVE_URL}; port 0 = any free port; '' = no server)", '-',
          read_only=True, validator=_ws_url),
    Param('metadata', '{}', "JSON object of the run (the recorder's 'irs_experiment' record): "
          'car size and arm geometry for the 3-D view', '-', read_only=True),
    Param('node_parameters', True, "when 'metadata' is '{}' (the view started by hand): ask "
          "the graph's nodes once for their parameters, draw the arm and the car with "
          "vehicle_sim's geometry (the defaults until it answers) and name the controller in "
          'the log', '-', read_only=True),
    Param('run_name', 'live', 'recording name shown by the viewer', '-', read_only=True),
    Param('period', 0.05, 'period of taking the messages (the batches sent to rerun and to '
          'Foxglove)', 's', 0.01, 1.0, read_only=True),
    Param('decimation', 10, 'rerun: decode and show one message in this many per topic (10: '
          '100 Hz of a 1 kHz topic; Foxglove gets every message)', '1', 1, 1000, read_only=True),
    Param('view_rate', 30.0, 'rate of the 3-D entities (car, arm) [0 = every decoded message]',
          'Hz', 0.0, 1000.0, read_only=True),
    Param('qos_depth', 100, 'KEEP_LAST depth of each best-effort subscription (messages a '
          'stalled view may skip beyond it are lost to the view, never to the graph)', '1', 1,
          10000, read_only=True),
]
