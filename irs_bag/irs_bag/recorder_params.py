"""Parameter table of the ``recorder`` node (no rclpy of its own; the QoS depth comes from
:mod:`irs_common.qos`).
"""
from irs_common.params import Param
from irs_common.qos import PUBLISHER_HISTORY

NODE_PARAMS = [
    Param('topics', ['*'], "topics to record; '*' (or any fnmatch pattern such as '/arm/*') "
          'records every matching topic that appears', '-', read_only=True),
    Param('exclude', ['/rosout', '/parameter_events', '/recorder/status'],
          'topics (fnmatch patterns) never recorded by a pattern', '-', read_only=True),
    Param('output', '', "bag directory to create (must not exist or be empty); '' = "
          'runs/bags/irs_bag_YYYY_MM_DD-HH_MM_SS under the working directory', '-',
          read_only=True),
    Param('metadata', '{}', "JSON object of string -> string written as MCAP metadata record "
          "'irs_experiment' (experiment file, parameters, versions, git commit)", '-',
          read_only=True),
    Param('node_parameters', True, "ask every other node of the graph for its parameters once "
          "and write them as MCAP metadata records 'irs_node_parameters' (a bag recorded by "
          "hand then names its controller and rig); the experiment runner writes the "
          "experiment's own in 'metadata' and sets this false", '-'),
    Param('compression', 'zstd', "chunk compression: 'zstd', 'lz4' or 'none'", '-',
          read_only=True),
    Param('chunk_size', 1 << 20, 'uncompressed chunk size', 'bytes', 1024, 1 << 30,
          read_only=True),
    Param('chunk_messages', 0, "the most messages in one chunk, 0 = no limit. mcap's writer "
          'holds the interpreter lock while it indexes a chunk (about 0.6 us a message): a '
          'recorder composed with a 1 kHz loop sets 512 (the experiment runner does), so the '
          'loop waits at most about 0.4 ms; each chunk keeps about 1.4 kB in memory until the '
          'bag closes', '1', 0, 1 << 20, read_only=True),
    Param('flush_period', 1.0, 'write buffered messages as a chunk at least this often (what '
          'a killed recorder can lose)', 's', 0.01, 3600.0, read_only=True),
    Param('discovery_period', 0.1, 'how often the graph is checked for topics to subscribe',
          's', 0.01, 60.0, read_only=True),
    # as deep as the IRS publishers' history: a recorder that stalls loses nothing they still hold
    Param('qos_depth', PUBLISHER_HISTORY, 'KEEP_LAST depth of each recording subscription', '1',
          1, 100000, read_only=True),
    Param('status_period', 1.0, "period of the 'recorder/status' JSON message (counts, drops; "
          '0 = off)', 's', 0.0, 3600.0, read_only=True),
    Param('final_drain', 0.1, 'on shutdown, keep draining until this long without traffic '
          '(at most 1 s)', 's', 0.0, 1.0, read_only=True),
]
