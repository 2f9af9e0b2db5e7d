"""What the benchmark scripts share: a ROS domain of their own, and writing the results."""
import datetime
import json
import os
from pathlib import Path

from irs_system_tests.domains import claim_domain

_held = []      # the open lock files of the domains this process holds


def domain(offset: int = 0) -> int:
    """Claim a free ROS domain id for the next measurement (the suite's allocator, so a bench
    run and a test run never share one), set ``ROS_DOMAIN_ID`` to it and return it; ``offset``
    starts the search elsewhere so that consecutive sections take different ids.
    """
    domain_id, lock = claim_domain(os.getpid() + offset)
    _held.append(lock)
    os.environ['ROS_DOMAIN_ID'] = str(domain_id)
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    return domain_id


def write_results(results: dict, out_dir, prefix: str = '') -> Path:
    """Add the load average, write ``<out_dir>/<prefix><time>.json``, print its path."""
    results['load_after'] = os.getloadavg()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{prefix}{datetime.datetime.now().strftime('%Y%m%d-%H%M%S')}.json"
    path.write_text(json.dumps(results, indent=1, default=str))
    print(f'results: {path}')
    return path
