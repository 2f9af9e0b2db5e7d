"""The Fast DDS XML profile file a process uses, and the longest heartbeat period it gives a
reliable writer.

Fast DDS 2.14 (the ros-jazzy wheels' rmw_fastrtps) reads one profile file at start-up, named by
``FASTRTPS_DEFAULT_PROFILES_FILE`` (Fast DDS 3 reads ``FASTDDS_DEFAULT_PROFILES_FILE``; either
counts here). rmw_fastrtps builds each publisher's writer from the file's default
``data_writer`` profile, or from a ``data_writer`` profile named after the topic, and then sets
the ROS QoS; the writer's ``times/heartbeatPeriod`` stays the file's. The writers of services
and clients take the profiles named ``service`` and ``client`` instead
(:data:`SERVICE_PROFILES`), which say nothing about a topic's writers. A reliable writer asks its
readers what they miss at each heartbeat and resends it, so a message lost on its way reaches a
reader at most about one heartbeat period later. The environment's file
(``env/fastdds_profiles.xml``) sets 50 ms; Fast DDS's own default is 3 s.
"""
import os
import xml.etree.ElementTree as ET

#: The environment variables naming a Fast DDS XML profile file (Fast DDS 2 reads the first).
PROFILE_VARIABLES = ('FASTRTPS_DEFAULT_PROFILES_FILE', 'FASTDDS_DEFAULT_PROFILES_FILE')
#: Fast DDS's heartbeat period of a reliable writer when no profile sets one [s].
DEFAULT_HEARTBEAT_PERIOD = 3.0
#: The profiles rmw_fastrtps applies to the writers of services and clients only.
SERVICE_PROFILES = ('service', 'client')


def profile_file(environ=os.environ) -> str | None:
    """The profile file ``environ`` names (the first of :data:`PROFILE_VARIABLES` set), or None."""
    for variable in PROFILE_VARIABLES:
        if environ.get(variable):
            return environ[variable]
    return None


def _seconds(element) -> float:
    """A Fast DDS duration element (``<sec>``, ``<nanosec>``, both optional) in seconds."""
    def part(name):
        child = next((c for c in element if c.tag.rsplit('}', 1)[-1] == name), None)
        return 0 if child is None or not (child.text or '').strip() else int(child.text)
    return part('sec') + part('nanosec') * 1e-9


def writer_heartbeat_period(environ=os.environ) -> float:
    """The longest heartbeat period [s] a topic's reliable writer in a process started with
    ``environ`` can have: the largest ``heartbeatPeriod`` of the file's ``data_writer`` profiles
    but those of :data:`SERVICE_PROFILES`, and :data:`DEFAULT_HEARTBEAT_PERIOD` for a writer no
    profile sets (no file, a file that cannot be read or parsed, no default ``data_writer``
    profile, or one without a ``heartbeatPeriod``).
    """
    path = profile_file(environ)
    if path is None:
        return DEFAULT_HEARTBEAT_PERIOD
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError, ValueError):
        return DEFAULT_HEARTBEAT_PERIOD
    writers = [e for e in root.iter() if e.tag.rsplit('}', 1)[-1] == 'data_writer'
               and e.get('profile_name') not in SERVICE_PROFILES]
    if not any(w.get('is_default_profile') == 'true' for w in writers):
        return DEFAULT_HEARTBEAT_PERIOD
    periods = []
    for writer in writers:
        found = [e for e in writer.iter() if e.tag.rsplit('}', 1)[-1] == 'heartbeatPeriod']
        try:
            periods.append(_seconds(found[0]) if found else DEFAULT_HEARTBEAT_PERIOD)
        except ValueError:
            periods.append(DEFAULT_HEARTBEAT_PERIOD)
    return max(periods)
