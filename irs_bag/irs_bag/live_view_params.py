"""Parameter table of the ``live_view`` node (no rclpy)."""
from irs_common.params import Param

#: rerun's default gRPC URL: a viewer started with ``rerun`` on this machine.
DEFAULT_URL = 'rerun+http://127.0.0.1:9876/proxy'

NODE_PARAMS = [
    Param('url', DEFAULT_URL, 'rerun viewer to stream to (its gRPC proxy URL)', '-',
          read_only=True),
    Param('save', '', "write an .rrd file here instead of streaming to 'url' ('' = stream)",
          '-', read_only=True),
    Param('metadata', '{}', "JSON object of the run (the recorder's 'irs_experiment' record): "
          'car size and arm geometry for the 3-D view', '-', read_only=True),
    Param('run_name', 'live', 'recording name shown by the viewer', '-', read_only=True),
    Param('period', 0.05, 'period of the batches sent to rerun (and of taking the messages)',
          's', 0.01, 1.0, read_only=True),
    Param('decimation', 10, 'decode and show one message in this many per topic (10: 100 Hz of '
          'a 1 kHz topic)', '1', 1, 1000, read_only=True),
    Param('view_rate', 30.0, 'rate of the 3-D entities (car, arm) [0 = every decoded message]',
          'Hz', 0.0, 1000.0, read_only=True),
    Param('qos_depth', 100, 'KEEP_LAST depth of each best-effort subscription (messages a '
          'stalled view may skip beyond it are lost to the view, never to the graph)', '1', 1,
          10000, read_only=True),
]
